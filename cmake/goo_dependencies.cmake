# Every third-party dependency, found once, with the Debian package that
# provides it named in the error (scripts/setup-deps installs them all).

macro(goo_require package debian_package)
  find_package(${package} ${ARGN} QUIET)
  if(NOT ${package}_FOUND)
    message(FATAL_ERROR
      "goo: dependency '${package}' not found. Install the Debian package "
      "'${debian_package}' (or run scripts/setup-deps).")
  endif()
endmacro()

goo_require(Eigen3 libeigen3-dev 3.4 NO_MODULE)
goo_require(TBB libtbb-dev)
goo_require(spdlog libspdlog-dev)
goo_require(fmt libfmt-dev)
goo_require(CHOLMOD libsuitesparse-dev)
set(BLA_VENDOR OpenBLAS)
goo_require(BLAS libopenblas-dev)
goo_require(tinyobjloader libtinyobjloader-dev)
goo_require(nlohmann_json nlohmann-json3-dev)
goo_require(CLI11 libcli11-dev)
goo_require(HDF5 libhdf5-dev COMPONENTS C)
# goo render: offscreen OpenGL (EGL with the desktop OpenGL library of
# glvnd; Mesa's libegl-mesa0 and libgl1-mesa-dri at run time) and libpng.
set(OpenGL_GL_PREFERENCE GLVND)
goo_require(OpenGL "libopengl-dev libegl-dev libgl-dev" COMPONENTS OpenGL EGL)
goo_require(PNG libpng-dev)

# CGAL configures its own build flags unless told not to touch them.
set(CGAL_DO_NOT_WARN_ABOUT_CMAKE_BUILD_TYPE TRUE)
set(CGAL_DATA_DIR "${PROJECT_SOURCE_DIR}/assets")
goo_require(CGAL libcgal-dev)

if(GOO_BUILD_TESTS)
  goo_require(GTest libgtest-dev)
endif()
if(GOO_BUILD_BENCH)
  goo_require(benchmark libbenchmark-dev)
endif()
