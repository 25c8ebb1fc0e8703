# cdsm.glsl, the GLSL include an application's shaders use, is one file for
# the application (share/cdsm/shaders/cdsm.glsl, cdsm::glsl_include()) kept
# as parts in content/shaders/cdsm/, joined here in this order at configure
# time (re-run when a part changes) into CDSM_GLSL in the build tree. The
# library embeds it (engine/gl), the package installs it, the tests read it.
set(CDSM_GLSL_PARTS interface views nodes receivers soft application)
set(CDSM_GLSL ${PROJECT_BINARY_DIR}/shaders/cdsm.glsl)

set(_cdsm_glsl_text "")
foreach(_part IN LISTS CDSM_GLSL_PARTS)
  set(_file ${PROJECT_SOURCE_DIR}/content/shaders/cdsm/${_part}.glsl)
  file(READ ${_file} _text)
  string(APPEND _cdsm_glsl_text "${_text}")
  set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_file})
endforeach()
file(WRITE ${CDSM_GLSL}.tmp "${_cdsm_glsl_text}")
file(COPY_FILE ${CDSM_GLSL}.tmp ${CDSM_GLSL} ONLY_IF_DIFFERENT)
file(REMOVE ${CDSM_GLSL}.tmp)
