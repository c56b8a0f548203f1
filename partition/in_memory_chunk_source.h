// placeholder, replaced by the lead
#pragma once
