# The package test (ctest package_consumer): installs the build into a
# private prefix, then configures, builds and runs tests/package/consumer
# against it as an application would (find_package(cdsm), cdsm::cdsm).
# Any failing step fails the test and shows that step's output.
#
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DGENERATOR=...
#         [-DMAKE_PROGRAM=...] [-DCXX_COMPILER=...] [-DBUILD_TYPE=...]
#         [-DEXPECT_GLSL=AUTO|ON|OFF] -P run_consumer.cmake
cmake_minimum_required(VERSION 3.25)

foreach(v BUILD_DIR SOURCE_DIR WORK_DIR GENERATOR)
  if(NOT DEFINED ${v} OR "${${v}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()
if(NOT DEFINED EXPECT_GLSL OR EXPECT_GLSL STREQUAL "")
  set(EXPECT_GLSL AUTO)
endif()

set(prefix "${WORK_DIR}/prefix")
set(consumer_build "${WORK_DIR}/consumer-build")
set(out_dir "${WORK_DIR}/out")
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${out_dir}")

# Runs a command; on failure stops with its output. Output goes to the
# variable named by the first argument.
function(step name out_var)
  string(TIMESTAMP t0 "%s")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  string(TIMESTAMP t1 "%s")
  math(EXPR dt "${t1} - ${t0}")
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message("---- ${name} failed (exit ${rc}): ${cmd}\n${out}")
    message(FATAL_ERROR "package_consumer: ${name} failed")
  endif()
  message(STATUS "${name}: ok (${dt} s)")
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

# 1. Install. ctest runs after the build, so everything is built; a build
#    tree whose targets are missing fails here (build all first).
set(config_args "")
if(BUILD_TYPE)
  set(config_args --config "${BUILD_TYPE}")
endif()
step("install into ${prefix}" install_out ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}" ${config_args})

# 2. The installed library resolves all of its dependencies.
file(GLOB_RECURSE libs LIST_DIRECTORIES false "${prefix}/lib*/libcdsm.so")
list(LENGTH libs n_libs)
if(NOT n_libs EQUAL 1)
  message(FATAL_ERROR "package_consumer: expected one libcdsm.so under ${prefix}, found '${libs}'\n${install_out}")
endif()
find_program(LDD ldd)
if(LDD)
  step("ldd libcdsm.so" ldd_out "${LDD}" "${libs}")
  if(ldd_out MATCHES "not found")
    message(FATAL_ERROR "package_consumer: the installed libcdsm.so has unresolved dependencies:\n${ldd_out}")
  endif()
endif()

# 2b. The README's library code (issue 33): every cpp block, extracted by
#     scripts/readme_snippets.py, compiles against the installed headers
#     with this build's compiler and with clang++ (-Werror=narrowing).
find_program(PYTHON3 python3)
find_program(CLANGXX NAMES clang++-14 clang++)
if(NOT PYTHON3)
  message(FATAL_ERROR "package_consumer: python3 is needed to extract the README's code")
endif()
step("extract the README's code" snippets_out "${PYTHON3}" "${SOURCE_DIR}/scripts/readme_snippets.py"
     "${SOURCE_DIR}/README.md" "${WORK_DIR}/readme")
string(STRIP "${snippets_out}" snippets_out)
string(REPLACE "\n" ";" snippets "${snippets_out}")
set(compilers "${CXX_COMPILER}")
if(NOT CXX_COMPILER)
  set(compilers c++)
endif()
if(CLANGXX)
  list(APPEND compilers "${CLANGXX}")
endif()
foreach(cxx IN LISTS compilers)
  foreach(snippet IN LISTS snippets)
    get_filename_component(name "${snippet}" NAME)
    step("README ${name} with ${cxx}" ignored "${cxx}" -std=c++17 -Werror=narrowing -fsyntax-only
         "-I${prefix}/include" "${snippet}")
  endforeach()
endforeach()

# 3. Configure the consumer against the prefix alone (no package registry),
#    with this build's generator and compiler.
if(EXPECT_GLSL STREQUAL "AUTO")
  if(EXISTS "${SOURCE_DIR}/content/shaders/cdsm/interface.glsl")
    set(EXPECT_GLSL ON)
  else()
    set(EXPECT_GLSL OFF)
  endif()
endif()
# The arguments that configure project `src` in `build` against the prefix
# alone (no package registry), with this build's generator and compiler.
function(application_args src build out_var)
  set(args -S "${src}" -B "${build}" -G "${GENERATOR}" "-DCMAKE_PREFIX_PATH=${prefix}"
      -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
  if(MAKE_PROGRAM)
    list(APPEND args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
  endif()
  if(CXX_COMPILER)
    list(APPEND args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
  endif()
  if(BUILD_TYPE)
    list(APPEND args "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}")
  endif()
  set(${out_var} ${args} PARENT_SCOPE)
endfunction()
application_args("${SOURCE_DIR}/tests/package/consumer" "${consumer_build}" configure_args)
list(APPEND configure_args "-DCDSM_CONSUMER_EXPECT_GLSL=${EXPECT_GLSL}")
step("configure the consumer" configure_out ${CMAKE_COMMAND} ${configure_args})
message("${configure_out}")
file(STRINGS "${consumer_build}/CMakeCache.txt" cdsm_dir_line REGEX "^cdsm_DIR:")
string(REGEX REPLACE "^cdsm_DIR:[A-Z]+=" "" cdsm_dir "${cdsm_dir_line}")
string(FIND "${cdsm_dir}" "${prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "package_consumer: find_package(cdsm) found '${cdsm_dir}', not the package in ${prefix}")
endif()

# 4. Build it (every installed header alone, then the program).
step("build the consumer" build_out ${CMAKE_COMMAND} --build "${consumer_build}" ${config_args})

# 5. The program's link line: libcdsm, nothing of its dependencies.
file(GLOB_RECURSE exe LIST_DIRECTORIES false "${consumer_build}/cdsm_consumer")
find_program(READELF readelf)
if(READELF)
  step("readelf cdsm_consumer" readelf_out "${READELF}" -d "${exe}")
  string(REGEX MATCHALL "\\(NEEDED\\)[^\n]*" needed "${readelf_out}")
  message(STATUS "cdsm_consumer needs: ${needed}")
  if(NOT needed MATCHES "libcdsm\\.so")
    message(FATAL_ERROR "package_consumer: cdsm_consumer does not link libcdsm:\n${readelf_out}")
  endif()
  # libOpenGL is the consumer's own (it builds a shader with cdsm.glsl).
  if(needed MATCHES "tbb|openvdb|tinygltf|stb|blosc|EGL|GLX|glfw|boost|Imath")
    message(FATAL_ERROR "package_consumer: the library's dependencies reached the application's link line:\n${needed}")
  endif()
endif()

# 6. Run it.
execute_process(COMMAND "${exe}" "${out_dir}" RESULT_VARIABLE rc OUTPUT_VARIABLE run_out ERROR_VARIABLE run_out)
message("${run_out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "package_consumer: cdsm_consumer failed (exit ${rc})")
endif()

# 7. The minimal engine sample (engine/examples/minimal): its own EGL
#    context, buffers and shader against the installed package; it exits
#    non-zero unless the ground under the translucent box reads 0.25 and
#    beside it 1.
set(minimal_build "${WORK_DIR}/minimal-build")
application_args("${SOURCE_DIR}/engine/examples/minimal" "${minimal_build}" minimal_args)
step("configure the minimal sample" minimal_configure ${CMAKE_COMMAND} ${minimal_args})
step("build the minimal sample" minimal_build_out ${CMAKE_COMMAND} --build "${minimal_build}" ${config_args})
file(GLOB_RECURSE minimal_exe LIST_DIRECTORIES false "${minimal_build}/cdsm_minimal")
step("run the minimal sample" minimal_out "${minimal_exe}")
message("${minimal_out}")
