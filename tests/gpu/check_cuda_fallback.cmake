# Issue 27 item 7 (tests/gpu/CMakeLists.txt, label unit, CUDA builds): the
# CUDA-built cdsm (-DEXE) and libcdsm.so (-DLIB, when built) need no
# libcudart (the runtime is linked statically), and `cdsm render` of a small
# frame on a machine without a CUDA device (CI) says "backend cpu: no CUDA
# device: ..." on stderr and exits 0 -- with no CUDA library path and no
# CDSM_CUDA_DISABLE, as a user without the toolkit would run it.
foreach(bin ${EXE} ${LIB})
  execute_process(COMMAND readelf -d ${bin} RESULT_VARIABLE rc OUTPUT_VARIABLE dyn ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "readelf -d ${bin} failed: ${err}")
  endif()
  if(dyn MATCHES "NEEDED[^\n]*libcudart")
    message(FATAL_ERROR "${bin} needs the shared CUDA runtime:\n${dyn}")
  endif()
  message(STATUS "ok: ${bin} needs no libcudart")
endforeach()

file(MAKE_DIRECTORY ${OUT})
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env --unset=CDSM_CUDA_DISABLE --unset=CDSM_CUDA_SYNC --unset=LD_LIBRARY_PATH
          ${EXE} render ${SCENE} --width 24 --height 16 --dsm-res 32 --fragments cpu -o ${OUT}/fallback.png
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "cdsm: backend [^\n]*" line "${err}")
if(EXISTS /dev/nvidiactl)
  message(STATUS "an NVIDIA device node exists here: the backend line is '${line}'")
  set(want "^cdsm: backend (cpu: no CUDA device: |cuda: )")
else()
  set(want "^cdsm: backend cpu: no CUDA device: ")
endif()
if(NOT rc EQUAL 0 OR NOT line MATCHES "${want}")
  message(FATAL_ERROR "cdsm render: exit ${rc}, backend line '${line}' (want exit 0 and '${want}')\nstderr:\n${err}")
endif()
if(NOT EXISTS ${OUT}/fallback.png)
  message(FATAL_ERROR "cdsm render exited 0 but wrote no image")
endif()
message(STATUS "ok: exit 0, '${line}'")
