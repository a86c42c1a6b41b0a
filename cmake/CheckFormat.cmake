# ctest script: fails listing every C++ source that clang-format would change.
file(GLOB_RECURSE files RELATIVE ${ROOT}
  ${ROOT}/sim/*.h ${ROOT}/sim/*.cpp ${ROOT}/rt/*.h ${ROOT}/rt/*.cpp
  ${ROOT}/drivers/*.h ${ROOT}/drivers/*.cpp ${ROOT}/tests/*.h ${ROOT}/tests/*.cpp)
set(bad "")
foreach(f IN LISTS files)
  execute_process(COMMAND ${CLANG_FORMAT} --dry-run --Werror --style=file ${f}
                  WORKING_DIRECTORY ${ROOT} RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
  if(NOT rc EQUAL 0)
    list(APPEND bad ${f})
  endif()
endforeach()
list(LENGTH files n)
if(bad)
  string(REPLACE ";" "\n  " badlist "${bad}")
  message(FATAL_ERROR "clang-format would change these files (run clang-format -i):\n  ${badlist}")
endif()
message(STATUS "${n} files formatted")
