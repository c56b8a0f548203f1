# Finds CHOLMOD from SuiteSparse. Debian's SuiteSparse 5.12 ships neither CMake
# config files nor a pkg-config file for it, so we look for the header and the
# libraries ourselves and wrap them into the imported target SuiteSparse::CHOLMOD.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
find_library(SUITESPARSE_CONFIG_LIBRARY suitesparseconfig)
find_library(AMD_LIBRARY amd)
find_library(COLAMD_LIBRARY colamd)
find_library(CAMD_LIBRARY camd)
find_library(CCOLAMD_LIBRARY ccolamd)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD DEFAULT_MSG
  CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY SUITESPARSE_CONFIG_LIBRARY AMD_LIBRARY COLAMD_LIBRARY)

if(CHOLMOD_FOUND AND NOT TARGET SuiteSparse::CHOLMOD)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${AMD_LIBRARY};${COLAMD_LIBRARY};${CAMD_LIBRARY};${CCOLAMD_LIBRARY};${SUITESPARSE_CONFIG_LIBRARY}")
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY SUITESPARSE_CONFIG_LIBRARY
  AMD_LIBRARY COLAMD_LIBRARY CAMD_LIBRARY CCOLAMD_LIBRARY)
