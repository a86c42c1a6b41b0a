# ctest script: the dependency rules (docs/design.md §2), checked on the sources under ROOT.
#   drivers/      include nothing of rt/
#   sim/          includes nothing of rt/ or drivers/, and calls no getenv (data folders and
#                 caches are passed in by the runtime)
#   sim/render/   includes nothing of sim/sensor, sim/astro or sim/sky (it reads messages,
#                 sim/msg)
# Fails listing every violation as file:line.
file(GLOB_RECURSE drivers_files RELATIVE ${ROOT} ${ROOT}/drivers/*.h ${ROOT}/drivers/*.cpp)
file(GLOB_RECURSE sim_files RELATIVE ${ROOT} ${ROOT}/sim/*.h ${ROOT}/sim/*.cpp)
set(bad "")

# check(FILES REGEX WHAT): every line of FILES matching REGEX is a violation.
function(check files regex what)
  foreach(f IN LISTS files)
    file(STRINGS ${ROOT}/${f} lines)
    set(n 0)
    foreach(line IN LISTS lines)
      math(EXPR n "${n} + 1")
      if(line MATCHES "${regex}")
        list(APPEND bad "${f}:${n}: ${what}")
      endif()
    endforeach()
  endforeach()
  set(bad ${bad} PARENT_SCOPE)
endfunction()

check("${drivers_files}" "^[ \t]*#[ \t]*include[ \t]*[\"<]rt/" "drivers/ includes rt/")
check("${sim_files}" "^[ \t]*#[ \t]*include[ \t]*[\"<](rt|drivers)/" "sim/ includes rt/ or drivers/")
check("${sim_files}" "getenv[ \t]*\\(" "sim/ calls getenv")
set(render_files "")
foreach(f IN LISTS sim_files)
  if(f MATCHES "^sim/render/")
    list(APPEND render_files ${f})
  endif()
endforeach()
check("${render_files}" "^[ \t]*#[ \t]*include[ \t]*[\"<]sim/(sensor|astro|sky)/"
      "sim/render includes sim/sensor, sim/astro or sim/sky")

list(LENGTH drivers_files nd)
list(LENGTH sim_files ns)
if(bad)
  string(REPLACE ";" "\n  " badlist "${bad}")
  message(FATAL_ERROR "dependency rules broken:\n  ${badlist}")
endif()
message(STATUS "dependency rules hold in ${nd} drivers/ and ${ns} sim/ files")
