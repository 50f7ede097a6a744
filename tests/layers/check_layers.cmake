# The layering check of tests/layers/CMakeLists.txt: cmake -DLAYERS=layers.txt -DSOURCE=<repo> -P this.
cmake_minimum_required(VERSION 3.25)  # script mode: the policies of this version (CMP0007, ...)
# Each problem is one line naming the target, or the file and line; exit status 1 if any.
# The floors and the walls are drawn in docs/design.md "Parts"; self_test.cmake shows that each
# rule below fails on a tree that breaks it.
set(allowed_dirs host/augerd tests/daemon tests/ros2 tests/interop)  # augerd and its own tests (interop: its MCAP log)
set(problems "")

# Every folder's floor, bottom up: a target links only targets of its own floor or below.
# The host: the core, io, then augerd / workbench / operator tools / interop, then the front.
set(floor_. 0)                # auger_protocol (shared/protocol.c)
set(floor_firmware 0)         # the firmware's hardware-free logic, on the protocol
set(floor_host 0)             # auger_core (host/src, host/include)
set(floor_host/io 1)          # auger_io
set(floor_host/ros2 2)        # auger_ros2, on io
set(floor_host/ros2_keys 2)   # auger_ros2_keys (auger ros2-keys), on io
set(floor_host/tools 2)       # auger-module
set(floor_host/track 2)       # auger-track
set(floor_host/wb_engine 2)   # auger_wb_engine, on the core
set(floor_host/augerd 3)
set(floor_host/workbench 3)
set(floor_host/operator 3)
set(floor_host/interop 3)
set(floor_host/auger 4)       # the front
# The simulator: the modules under simavr (no host code), the robot on the core and io, the
# firmware-in-the-loop rig on the operator's step figures. Then the bench, then the tests (every
# folder under tests/): the tests may use what the bench offers, the bench never uses tests/.
set(floor_sim 1)
set(floor_sim/robot 2)
set(floor_sim/rig 4)
set(floor_bench 5)
set(floor_tests 6)
# The host is what runs on the robot and at the researcher's desk: no host target links the
# simulator, the bench or the tests, directly or through another library (the workbench has to
# find effects from data, not from the code that produced the data).
set(walled_off "^(sim|bench|tests)(/|$)")

# A folder's key in the floors above: its path, or "tests" for every folder under tests/.
function(floor_key dir out)
  if(dir MATCHES "^tests(/|$)")
    set(${out} tests PARENT_SCOPE)
  else()
    set(${out} ${dir} PARENT_SCOPE)
  endif()
endfunction()

# The rows: target|folder|link,link,...
file(STRINGS ${LAYERS} rows)
set(all_targets "")
foreach(row IN LISTS rows)
  string(REPLACE "," ";" row "${row}")
  string(REPLACE "|" ";" f "${row}")
  list(GET f 0 t)
  list(GET f 1 d)
  list(LENGTH f n)
  set(links "")
  if(n GREATER 2)
    list(SUBLIST f 2 -1 links)
  endif()
  set(dir_${t} ${d})
  floor_key(${d} key)
  set(key_${t} ${key})
  set(links_${t} ${links})
  list(APPEND all_targets ${t})
endforeach()

# 1. Links through the transitive closure of each target's link list: augerd_lib (augerd's
#    private library) only in augerd and its tests; nothing of the simulator, the bench or the
#    tests in a host target. The problem names the chain of links.
foreach(t IN LISTS all_targets)
  set(seen "")
  set(todo "")
  foreach(l IN LISTS links_${t})
    if(NOT DEFINED parent_${l})
      set(parent_${l} ${t})
      list(APPEND todo ${l})
    endif()
  endforeach()
  while(todo)
    list(POP_FRONT todo l)
    list(APPEND seen ${l})
    foreach(m IN LISTS links_${l})
      if(NOT DEFINED parent_${m} AND NOT m STREQUAL t)
        set(parent_${m} ${l})
        list(APPEND todo ${m})
      endif()
    endforeach()
  endwhile()
  foreach(l IN LISTS seen)
    set(forbidden "")
    if(l STREQUAL "augerd_lib" AND NOT dir_${t} IN_LIST allowed_dirs)
      set(forbidden "augerd's private library")
    elseif(dir_${t} MATCHES "^host(/|$)" AND DEFINED dir_${l} AND dir_${l} MATCHES "${walled_off}")
      set(forbidden "the simulator, the bench or the tests (the host never links them)")
    endif()
    if(forbidden)
      set(chain "")
      set(p ${parent_${l}})
      while(NOT p STREQUAL t)
        list(PREPEND chain ${p})
        set(p ${parent_${p}})
      endwhile()
      set(through "")
      if(chain)
        list(JOIN chain " -> " chain)
        set(through " through ${chain}")
      endif()
      string(APPEND problems "target ${t} (${dir_${t}}) links ${l} (${dir_${l}})${through}: ${forbidden}\n")
    endif()
  endforeach()
  foreach(l IN LISTS seen)
    unset(parent_${l})
  endforeach()
endforeach()

# 2. The floors: every folder with a target has one, and no target links one of a floor above.
foreach(t IN LISTS all_targets)
  set(k ${key_${t}})
  if(NOT DEFINED floor_${k})
    string(APPEND problems "target ${t} (${dir_${t}}): a folder without a floor in check_layers.cmake\n")
    continue()
  endif()
  foreach(l IN LISTS links_${t})
    if(DEFINED key_${l} AND DEFINED floor_${key_${l}})
      set(fl ${floor_${key_${l}}})
      if(fl GREATER floor_${k})
        string(APPEND problems
               "target ${t} (${dir_${t}}, floor ${floor_${k}}) links ${l} (${dir_${l}}, floor ${fl}), a floor above it\n")
      endif()
    endif()
  endforeach()
endforeach()

# 3. Includes. The headers of the tree by name and by where they live: tests/ (the tests'),
#    sim/ and bench/ (the simulator's and the bench's), the rest (shared/, firmware/, host/).
set(code_dirs host shared firmware sim bench tests)
set(headers "")
foreach(top IN LISTS code_dirs)
  file(GLOB_RECURSE h RELATIVE ${SOURCE} ${SOURCE}/${top}/*.h ${SOURCE}/${top}/*.hpp)
  list(APPEND headers ${h})
endforeach()
foreach(h IN LISTS headers)
  get_filename_component(hn ${h} NAME)
  if(h MATCHES "^tests/")
    set(area tests)
  elseif(h MATCHES "^(sim|bench)/")
    set(area simbench)
  else()
    set(area base)
  endif()
  if(NOT DEFINED hdr_${area}_${hn})
    set(hdr_${area}_${hn} ${h})
  endif()
endforeach()
file(GLOB augerd_headers RELATIVE ${SOURCE}/host/augerd ${SOURCE}/host/augerd/*.hpp ${SOURCE}/host/augerd/*.h)
set(sources "")
foreach(top IN LISTS code_dirs)
  file(GLOB_RECURSE s RELATIVE ${SOURCE} ${SOURCE}/${top}/*.c ${SOURCE}/${top}/*.cpp ${SOURCE}/${top}/*.h
       ${SOURCE}/${top}/*.hpp)
  list(APPEND sources ${s})
endforeach()

# The line of `file` that includes `header` (only called for a problem).
function(include_line file header out)
  file(STRINGS ${SOURCE}/${file} lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    string(FIND "${line}" "\"${header}\"" at)
    if(at GREATER -1 AND line MATCHES "^[ \t]*#[ \t]*include")
      set(${out} "${file}:${n}" PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${out} ${file} PARENT_SCOPE)
endfunction()

foreach(s IN LISTS sources)
  get_filename_component(d ${s} DIRECTORY)
  file(STRINGS ${SOURCE}/${s} incs REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(inc IN LISTS incs)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]*)\".*" "\\1" h "${inc}")
    get_filename_component(hn ${h} NAME)
    set(why "")
    if(NOT d IN_LIST allowed_dirs AND (hn IN_LIST augerd_headers OR h MATCHES "augerd/"))
      set(why "a header of augerd (host/augerd)")
    elseif(hn STREQUAL "subcommand.hpp" AND NOT d STREQUAL "host/auger")
      set(why "the auger front's subcommand.hpp (host/auger), a layer above it")
    elseif(NOT s MATCHES "^tests/" AND DEFINED hdr_tests_${hn} AND NOT DEFINED hdr_base_${hn}
           AND NOT DEFINED hdr_simbench_${hn})
      set(why "a header of the tests (${hdr_tests_${hn}}); only tests/ includes them")
    elseif(s MATCHES "^host/" AND NOT DEFINED hdr_base_${hn}
           AND (DEFINED hdr_simbench_${hn} OR DEFINED hdr_tests_${hn}))
      set(where ${hdr_simbench_${hn}} ${hdr_tests_${hn}})
      list(GET where 0 where)
      set(why "a header of the simulator, the bench or the tests (${where}); the host never uses them")
    endif()
    if(why)
      include_line(${s} ${h} at)
      string(APPEND problems "${at}: includes \"${h}\", ${why}\n")
    endif()
  endforeach()
endforeach()

if(problems)
  message(FATAL_ERROR "layering broken (tests/layers/CMakeLists.txt):\n${problems}")
endif()
list(LENGTH all_targets nt)
list(LENGTH sources ns)
message(STATUS "layers: ${nt} targets and ${ns} source files checked")
