# Issue 27 item 1 (tests/gpu/CMakeLists.txt, label unit, CUDA builds): the
# logic of scripts/gpu/build_kit.sh on a small kit -- this build's CUDA-built
# cdsm (-DEXE), stripped, with every library it loads from outside the
# allowed list copied from the installed Debian packages -- passes the kit's
# ldd-closure check (no libcudart, everything inside the folder, <= MAX_MIB);
# then, with one carried library deleted, the check must fail.
set(ENV{CDSM_KIT_MAX_MIB} ${MAX_MIB})
execute_process(COMMAND bash ${SCRIPT} --small ${DIR} ${EXE} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "build_kit.sh --small: exit ${rc}")
endif()
file(GLOB_RECURSE libs LIST_DIRECTORIES false ${DIR}/root/*.so.*)
list(LENGTH libs n)
if(n EQUAL 0)
  message(FATAL_ERROR "the small kit carries no library: ${EXE} loads nothing beyond the allowed list?")
endif()
# Take out one carried library the program itself needs: the check must see it resolve outside.
execute_process(COMMAND readelf -d ${EXE} OUTPUT_VARIABLE dyn)
set(victim "")
foreach(l ${libs})
  get_filename_component(name ${l} NAME)
  string(REGEX REPLACE "^(lib[^.]*\\.so\\.[0-9]+).*" "\\1" soname "${name}")
  if(dyn MATCHES "NEEDED[^\n]*\\[${soname}\\]" AND NOT IS_SYMLINK ${l})
    set(victim ${l})
    break()
  endif()
endforeach()
if(NOT victim)
  message(FATAL_ERROR "no carried library of ${EXE}'s own NEEDED list found in the kit")
endif()
file(REMOVE ${victim})
execute_process(COMMAND bash ${SCRIPT} --check ${DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
message(STATUS "without ${victim}:\n${out}")
if(rc EQUAL 0)
  message(FATAL_ERROR "the check passed a kit without ${victim}")
endif()
message(STATUS "ok: the small kit passed, and failed without one of its libraries")
