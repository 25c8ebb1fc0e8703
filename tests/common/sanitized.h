// CDSM_TEST_SANITIZED: 1 in an AddressSanitizer or ThreadSanitizer build,
// with gcc (__SANITIZE_ADDRESS__) or clang (__has_feature), else 0. Tests
// that scale their work down under a sanitizer (10-20x slower) or skip what
// sanitizers cannot do (address-space limits) test this one macro.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define CDSM_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define CDSM_TEST_SANITIZED 1
#endif
#endif
#ifndef CDSM_TEST_SANITIZED
#define CDSM_TEST_SANITIZED 0
#endif
