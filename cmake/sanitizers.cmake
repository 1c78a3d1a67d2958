# SPLITRAY_SANITIZE: the sanitizers every target is compiled and linked with, a list of
# address, undefined, leak, thread ("address;undefined", "thread"); ON means address;undefined.
# Sets SPLITRAY_SANITIZERS (the normalised list, empty when off) and SPLITRAY_SANITIZE_FLAGS
# (the compile flags, also handed to package_test's consumer, which links our static libraries).
set(SPLITRAY_SANITIZE "" CACHE STRING
  "Sanitizers for every target: address;undefined, thread (ON = address;undefined; empty = none)")
set(SPLITRAY_SANITIZERS "")
set(SPLITRAY_SANITIZE_FLAGS "")
if(SPLITRAY_SANITIZE MATCHES "^(ON|on|On|TRUE|true|YES|yes|1)$")
  set(SPLITRAY_SANITIZERS address undefined)
elseif(SPLITRAY_SANITIZE AND NOT SPLITRAY_SANITIZE MATCHES "^(OFF|off|Off|FALSE|false|NO|no|0)$")
  string(REPLACE "," ";" SPLITRAY_SANITIZERS "${SPLITRAY_SANITIZE}")
endif()
foreach(sanitizer IN LISTS SPLITRAY_SANITIZERS)
  if(NOT sanitizer MATCHES "^(address|undefined|leak|thread)$")
    message(FATAL_ERROR "SPLITRAY_SANITIZE: unknown sanitizer '${sanitizer}' "
                        "(known: address, undefined, leak, thread)")
  endif()
endforeach()
if("thread" IN_LIST SPLITRAY_SANITIZERS AND ("address" IN_LIST SPLITRAY_SANITIZERS OR
                                             "leak" IN_LIST SPLITRAY_SANITIZERS))
  message(FATAL_ERROR "SPLITRAY_SANITIZE: thread cannot be combined with address or leak")
endif()
if(SPLITRAY_SANITIZERS)
  list(JOIN SPLITRAY_SANITIZERS "," joined)
  set(SPLITRAY_SANITIZE_FLAGS -fsanitize=${joined} -fno-omit-frame-pointer)
  # A UBSan finding aborts the program (a failed test), not just a line in its output.
  if("undefined" IN_LIST SPLITRAY_SANITIZERS)
    list(APPEND SPLITRAY_SANITIZE_FLAGS -fno-sanitize-recover=undefined)
  endif()
  add_compile_options(${SPLITRAY_SANITIZE_FLAGS})
  add_link_options(-fsanitize=${joined})
  message(STATUS "Sanitizers: ${joined}")
endif()

# SPLITRAY_FUZZ: the libFuzzer targets of fuzz/ (clang only). Every target gets libFuzzer's
# coverage instrumentation and ASan + UBSan; only the fuzz executables link libFuzzer's main.
option(SPLITRAY_FUZZ "Build the libFuzzer targets in fuzz/ (clang; ASan + UBSan)" OFF)
if(SPLITRAY_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "SPLITRAY_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  if(SPLITRAY_SANITIZERS)
    message(FATAL_ERROR "SPLITRAY_FUZZ brings its own sanitizers (address, undefined): "
                        "leave SPLITRAY_SANITIZE empty")
  endif()
  set(SPLITRAY_SANITIZERS address undefined)
  set(SPLITRAY_SANITIZE_FLAGS -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                              -fno-sanitize-recover=undefined)
  add_compile_options(${SPLITRAY_SANITIZE_FLAGS})
  add_link_options(-fsanitize=address,undefined)
endif()

# The environment of every test of a sanitized build: the suppressions (scripts/*.supp, each
# entry says why) and stack traces with UBSan's reports.
set(SPLITRAY_SANITIZER_ENVIRONMENT "")
if("address" IN_LIST SPLITRAY_SANITIZERS OR "leak" IN_LIST SPLITRAY_SANITIZERS)
  list(APPEND SPLITRAY_SANITIZER_ENVIRONMENT
    "LSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/scripts/lsan.supp")
endif()
if("undefined" IN_LIST SPLITRAY_SANITIZERS)
  list(APPEND SPLITRAY_SANITIZER_ENVIRONMENT "UBSAN_OPTIONS=print_stacktrace=1")
endif()
if("thread" IN_LIST SPLITRAY_SANITIZERS)
  list(APPEND SPLITRAY_SANITIZER_ENVIRONMENT
    "TSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/scripts/tsan.supp halt_on_error=1 second_deadlock_stack=1")
endif()
