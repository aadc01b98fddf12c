# FindCHOLMOD: SuiteSparse's sparse Cholesky (Debian's SuiteSparse 5.12 ships
# no CMake config). Defines the imported target CHOLMOD::CHOLMOD.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
find_library(CHOLMOD_SUITESPARSECONFIG_LIBRARY suitesparseconfig)
find_library(CHOLMOD_AMD_LIBRARY amd)
find_library(CHOLMOD_CAMD_LIBRARY camd)
find_library(CHOLMOD_COLAMD_LIBRARY colamd)
find_library(CHOLMOD_CCOLAMD_LIBRARY ccolamd)

if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/cholmod.h")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/cholmod.h" _cholmod_version_lines
       REGEX "#define CHOLMOD_(MAIN|SUB)_VERSION")
  string(REGEX REPLACE ".*MAIN_VERSION +([0-9]+).*" "\\1" _main "${_cholmod_version_lines}")
  string(REGEX REPLACE ".*SUB_VERSION +([0-9]+).*" "\\1" _sub "${_cholmod_version_lines}")
  set(CHOLMOD_VERSION "${_main}.${_sub}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR CHOLMOD_SUITESPARSECONFIG_LIBRARY
                CHOLMOD_AMD_LIBRARY CHOLMOD_COLAMD_LIBRARY
  VERSION_VAR CHOLMOD_VERSION)

if(CHOLMOD_FOUND AND NOT TARGET CHOLMOD::CHOLMOD)
  add_library(CHOLMOD::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(CHOLMOD::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}")
  set(_deps ${CHOLMOD_AMD_LIBRARY} ${CHOLMOD_COLAMD_LIBRARY} ${CHOLMOD_SUITESPARSECONFIG_LIBRARY})
  foreach(_lib CHOLMOD_CAMD_LIBRARY CHOLMOD_CCOLAMD_LIBRARY)
    if(${_lib})
      list(APPEND _deps ${${_lib}})
    endif()
  endforeach()
  set_property(TARGET CHOLMOD::CHOLMOD PROPERTY INTERFACE_LINK_LIBRARIES "${_deps}")
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY CHOLMOD_SUITESPARSECONFIG_LIBRARY
  CHOLMOD_AMD_LIBRARY CHOLMOD_CAMD_LIBRARY CHOLMOD_COLAMD_LIBRARY CHOLMOD_CCOLAMD_LIBRARY)
