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

add_library(cdsm_fp INTERFACE)
if(CDSM_FP_STRICT)
  target_compile_options(cdsm_fp INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-ffp-contract=off>
                                           $<$<COMPILE_LANGUAGE:CUDA>:--fmad=false>)
endif()
