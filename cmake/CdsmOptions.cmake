# Interface targets carrying the project's flags (no global flag edits).
add_library(cdsm_warnings INTERFACE)
target_compile_options(cdsm_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-unused-parameter -Wno-missing-field-initializers>)

add_library(cdsm_sanitize INTERFACE)
if(CDSM_SANITIZE)
  target_compile_options(cdsm_sanitize INTERFACE
    $<$<COMPILE_LANGUAGE:CXX>:-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined>)
  target_link_options(cdsm_sanitize INTERFACE -fsanitize=address,undefined)
endif()

# Fuzz builds (CDSM_FUZZ, clang only): everything that links cdsm_sanitize
# (the engine, the shadows and cluster libraries) gets libFuzzer's coverage
# instrumentation; the fuzz targets link cdsm_fuzz, which adds libFuzzer's main.
add_library(cdsm_fuzz INTERFACE)
if(CDSM_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "CDSM_FUZZ needs clang (libFuzzer), e.g. -DCMAKE_CXX_COMPILER=clang++-14; see scripts/fuzz.sh")
  endif()
  target_compile_options(cdsm_sanitize INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-fsanitize=fuzzer-no-link>)
  target_compile_options(cdsm_fuzz INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-fsanitize=fuzzer>)
  target_link_options(cdsm_fuzz INTERFACE -fsanitize=fuzzer)
endif()

add_library(cdsm_fp INTERFACE)
if(CDSM_FP_STRICT)
  target_compile_options(cdsm_fp INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-ffp-contract=off>
                                           $<$<COMPILE_LANGUAGE:CUDA>:--fmad=false>)
endif()

# OpenVDB ships its find module (FindOpenVDB.cmake) in <libdir>/cmake/OpenVDB
# — on Debian /usr/lib/<multiarch>/cmake/OpenVDB — where CMake does not
# look by itself. cdsm_find_openvdb() finds that directory (cache variable
# CDSM_OPENVDB_MODULE_DIR: set it for an OpenVDB elsewhere), adds it to the
# module path and finds the package (OpenVDB::openvdb). A macro: the module
# path and the package's variables stay in the caller's scope.
macro(cdsm_find_openvdb)
  find_path(CDSM_OPENVDB_MODULE_DIR FindOpenVDB.cmake
            PATHS ${CMAKE_PREFIX_PATH} /usr/local /usr
            PATH_SUFFIXES lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB lib/cmake/OpenVDB lib64/cmake/OpenVDB
            DOC "Directory of OpenVDB's FindOpenVDB.cmake"
            NO_DEFAULT_PATH)
  if(NOT CDSM_OPENVDB_MODULE_DIR)
    message(FATAL_ERROR "cdsm: OpenVDB's FindOpenVDB.cmake not found (Debian: libopenvdb-dev); set "
                        "CDSM_OPENVDB_MODULE_DIR to its directory, or -DCDSM_VDB=OFF to build without .vdb files")
  endif()
  list(APPEND CMAKE_MODULE_PATH ${CDSM_OPENVDB_MODULE_DIR})
  find_package(OpenVDB REQUIRED QUIET)
endmacro()
