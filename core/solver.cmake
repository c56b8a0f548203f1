# Linearization, reduce pass, initialization, Levenberg-Marquardt driver.
target_sources(graphslam_core PRIVATE)
