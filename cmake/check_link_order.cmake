# Checks that the cdsm program links the CPU backend's archive before the
# CUDA one (engine/CMakeLists.txt): the CUDA objects carry host copies of
# the inline CDSM_HD functions, and the linker keeps the first copy it
# meets — nvcc's made the CPU camera pass 15% slower. Reads the Ninja build
# file: -DNINJA_FILE=<build>/build.ninja.
file(STRINGS "${NINJA_FILE}" lines)
set(found FALSE)
set(in_cdsm FALSE)
foreach(line IN LISTS lines)
  if(line MATCHES "^build cdsm: ")
    set(in_cdsm TRUE)
  elseif(in_cdsm AND line MATCHES "^  LINK_LIBRARIES = (.*)$")
    set(libs "${CMAKE_MATCH_1}")
    string(FIND "${libs}" "libcdsm_shadows.a" shadows)
    string(FIND "${libs}" "libcdsm_cuda.a" cuda)
    if(shadows EQUAL -1 OR cuda EQUAL -1)
      message(FATAL_ERROR "cdsm's link line names no libcdsm_shadows.a or libcdsm_cuda.a:\n${libs}")
    endif()
    if(NOT shadows LESS cuda)
      message(FATAL_ERROR "cdsm links libcdsm_cuda.a before libcdsm_shadows.a: the CPU camera pass would run "
                          "nvcc's host copies of the lookups:\n${libs}")
    endif()
    set(found TRUE)
    break()
  elseif(in_cdsm AND line MATCHES "^build ")
    break()
  endif()
endforeach()
if(NOT found)
  message(FATAL_ERROR "no link line of cdsm in ${NINJA_FILE}")
endif()
message(STATUS "cdsm links the CPU backend before the CUDA backend")
