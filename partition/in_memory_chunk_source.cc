#include "partition/in_memory_chunk_source.h"
