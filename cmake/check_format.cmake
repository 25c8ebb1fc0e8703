# ctest clang_format: every C++ and CUDA source of the tree is as
# .clang-format formats it. Run with -DCLANG_FORMAT=<program> -DSRC=<root>.
# Fix with: clang-format-14 -i <the files named>.
file(GLOB_RECURSE sources LIST_DIRECTORIES false
     ${SRC}/engine/*.h ${SRC}/engine/*.cpp ${SRC}/shadows/*.h ${SRC}/shadows/*.cpp
     ${SRC}/cuda/*.h ${SRC}/cuda/*.cu ${SRC}/cuda/*.cuh ${SRC}/editor/*.h ${SRC}/editor/*.cpp
     ${SRC}/tests/*.h ${SRC}/tests/*.cpp ${SRC}/tests/*.cu)
# One process for all files (a process each costs ~30 s on two cores).
execute_process(COMMAND ${CLANG_FORMAT} --style=file --dry-run --Werror ${sources}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
list(LENGTH sources n)
if(NOT rc EQUAL 0)
  string(REGEX MATCHALL "[^\n]*: error: code should be clang-formatted" hits "${out}")
  set(files "")
  foreach(h IN LISTS hits)
    string(REGEX REPLACE ":[0-9]+:[0-9]+: error: code should be clang-formatted$" "" f "${h}")
    file(RELATIVE_PATH rel ${SRC} ${f})
    list(APPEND files ${rel})
  endforeach()
  list(REMOVE_DUPLICATES files)
  list(JOIN files "\n  " listed)
  message(FATAL_ERROR "not formatted as .clang-format says (clang-format-14 -i FILE):\n  ${listed}\n${out}")
endif()
message(STATUS "${n} sources formatted as .clang-format says")
