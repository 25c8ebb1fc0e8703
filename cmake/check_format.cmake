# ctest clang_format: every C++ and CUDA source of the tree is as
# .clang-format formats it. Run with -DCLANG_FORMAT=<program> -DSRC=<root>.
# Fix with: clang-format-14 -i <the files named>.
file(GLOB_RECURSE sources LIST_DIRECTORIES false
     ${SRC}/engine/*.h ${SRC}/engine/*.cpp ${SRC}/shadows/*.h ${SRC}/shadows/*.cpp
     ${SRC}/cuda/*.h ${SRC}/cuda/*.cu ${SRC}/cuda/*.cuh ${SRC}/editor/*.h ${SRC}/editor/*.cpp
     ${SRC}/tests/*.h ${SRC}/tests/*.cpp ${SRC}/tests/*.cu)
set(unformatted "")
foreach(f IN LISTS sources)
  execute_process(COMMAND ${CLANG_FORMAT} --style=file --dry-run --Werror ${f}
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
  if(NOT rc EQUAL 0)
    file(RELATIVE_PATH rel ${SRC} ${f})
    list(APPEND unformatted ${rel})
  endif()
endforeach()
list(LENGTH sources n)
if(unformatted)
  list(JOIN unformatted "\n  " listed)
  message(FATAL_ERROR "not formatted as .clang-format says (clang-format-14 -i FILE):\n  ${listed}")
endif()
message(STATUS "${n} sources formatted as .clang-format says")
