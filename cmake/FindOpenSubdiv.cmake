# Debian 12's OpenSubdiv CMake config references static libraries that libosd-dev does not
# ship, so config mode fails hard. This module finds the shared osdCPU library directly and
# keeps the upstream target name OpenSubdiv::osdCPU.
find_path(OpenSubdiv_INCLUDE_DIR opensubdiv/version.h)
find_library(OpenSubdiv_osdCPU_LIBRARY osdCPU)
if(OpenSubdiv_INCLUDE_DIR)
  file(STRINGS "${OpenSubdiv_INCLUDE_DIR}/opensubdiv/version.h" _osd_version_lines
       REGEX "define OPENSUBDIV_VERSION_(MAJOR|MINOR|PATCH) ")
  string(REGEX REPLACE ".*MAJOR ([0-9]+).*MINOR ([0-9]+).*PATCH ([0-9]+).*" "\\1.\\2.\\3"
         OpenSubdiv_VERSION "${_osd_version_lines}")
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenSubdiv
  REQUIRED_VARS OpenSubdiv_osdCPU_LIBRARY OpenSubdiv_INCLUDE_DIR VERSION_VAR OpenSubdiv_VERSION)
if(OpenSubdiv_FOUND AND NOT TARGET OpenSubdiv::osdCPU)
  add_library(OpenSubdiv::osdCPU SHARED IMPORTED)
  set_target_properties(OpenSubdiv::osdCPU PROPERTIES
    IMPORTED_LOCATION "${OpenSubdiv_osdCPU_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${OpenSubdiv_INCLUDE_DIR}")
endif()
mark_as_advanced(OpenSubdiv_INCLUDE_DIR OpenSubdiv_osdCPU_LIBRARY)
