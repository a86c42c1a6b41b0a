# Shared build settings for every nvstim target.

# Warnings as errors live in one INTERFACE target that every target links (docs/style.md §15).
add_library(nvs_warnings INTERFACE)
target_compile_options(nvs_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion
  -Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual
  -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
if(NVS_WERROR)
  target_compile_options(nvs_warnings INTERFACE -Werror)
endif()
# GCC 12 at -O3 inlines std::string's copies (operator+ of a literal and a string, assignment
# of a literal) into memcpy calls it cannot prove disjoint and reports -Wrestrict on correct
# code (GCC bug 105329; Debian 12 has GCC 12.2). The warning is a compiler defect, and it
# fires wherever the optimiser inlines differently, so it is off for GCC 12 only.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(nvs_warnings INTERFACE -Wno-restrict)
endif()

add_library(nvs_sanitizers INTERFACE)
if((NVS_SANITIZE OR NVS_FUZZ) AND NVS_TSAN)
  # The runtimes of ASan and TSan cannot be linked into one program.
  message(FATAL_ERROR "NVS_SANITIZE and NVS_TSAN are exclusive: configure two build folders")
endif()
if(NVS_SANITIZE)
  target_compile_options(nvs_sanitizers INTERFACE
    -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_link_options(nvs_sanitizers INTERFACE -fsanitize=address,undefined)
endif()
if(NVS_FUZZ)
  # libFuzzer's coverage instrumentation with ASan and UBSan on every nvstim target; the
  # fuzz executables add the fuzzer's main (tests/fuzz). Any UB report aborts the run.
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "NVS_FUZZ needs clang (libFuzzer): use the `fuzz` preset")
  endif()
  target_compile_options(nvs_sanitizers INTERFACE
    -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined)
  target_link_options(nvs_sanitizers INTERFACE -fsanitize=address,undefined)
endif()
if(NVS_TSAN)
  # ThreadSanitizer: every nvstim target is instrumented; the Debian libraries are not, so
  # a race inside one of them shows only where it touches our memory.
  target_compile_options(nvs_sanitizers INTERFACE -fsanitize=thread -fno-omit-frame-pointer)
  target_link_options(nvs_sanitizers INTERFACE -fsanitize=thread)
  # One code path per function instead of GCC's target_clones: the ifunc resolver that picks a
  # clone runs while the program is being relocated, before the TSan runtime is initialised,
  # and, instrumented, crashes every test program at load. The clones compute the same bits, so
  # the baseline path tests the same logic.
  target_compile_definitions(nvs_sanitizers INTERFACE NVS_SINGLE_TARGET)
endif()

# nvs_add_library(NAME SOURCES... [DEPS ...]): a folder's library, named after its path
# (sim/core -> nvs_sim_core), with the project's include root and warnings.
function(nvs_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE nvs_warnings nvs_sanitizers ${ARG_PRIVATE_DEPS})
  target_link_libraries(${name} INTERFACE nvs_sanitizers)
endfunction()

# nvs_add_test(NAME [SERIAL] SOURCES... DEPS ...): one GoogleTest executable per source folder.
# SERIAL: its tests measure wall-clock timing and run alone (ctest RUN_SERIAL), so that the
# other tests running in parallel on a 2-core machine cannot make them miss deadlines.
function(nvs_add_test name)
  cmake_parse_arguments(ARG "SERIAL" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main
                        nvs_warnings nvs_sanitizers)
  target_compile_definitions(${name} PRIVATE
    NVS_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    NVS_BINARY_DIR="${PROJECT_BINARY_DIR}"
    NVS_TEST_DATA_DIR="${NVS_TEST_DATA_DIR}")
  set(serial FALSE)
  if(ARG_SERIAL)
    set(serial TRUE)
  endif()
  set(env "NVS_CONFIG_DIR=${PROJECT_SOURCE_DIR}/config" "NVS_CACHE_DIR=${PROJECT_BINARY_DIR}/cache")
  if(NVS_SANITIZE)
    # Leaks of third-party libraries only (cmake/lsan-suppressions.txt).
    list(APPEND env "LSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/cmake/lsan-suppressions.txt")
  endif()
  # The environment as a command prefix (env VAR=... test), which gtest_discover_tests puts before
  # the listing run and every test it adds. Not PROPERTIES ENVIRONMENT: CMake 3.25's
  # GoogleTestAddTests passes each element of a list value on as its own argument to
  # set_tests_properties, so the second variable became a property name and RUN_SERIAL was lost
  # (`ctest --show-only=json-v1` showed ENVIRONMENT with NVS_CONFIG_DIR alone and no RUN_SERIAL).
  set_target_properties(${name} PROPERTIES CROSSCOMPILING_EMULATOR "/usr/bin/env;${env}")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES RUN_SERIAL ${serial})
endfunction()
