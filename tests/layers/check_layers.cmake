# The layering check of tests/layers/CMakeLists.txt: cmake -DLAYERS=layers.txt -DSOURCE=<repo> -P this.
cmake_minimum_required(VERSION 3.25)  # script mode: the policies of this version (CMP0007, ...)
# Each problem is one line naming the target or the file and line; exit status 1 if any.
set(allowed_dirs host/augerd tests/daemon tests/ros2 tests/interop)  # augerd and its own tests (interop: its MCAP log)
set(problems "")

# 1. Links to augerd_lib: the transitive closure of each target's link list.
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
  set(links_${t} ${links})
  list(APPEND all_targets ${t})
endforeach()
foreach(t IN LISTS all_targets)
  set(seen "")
  set(todo ${links_${t}})
  set(path_to_augerd "")
  while(todo)
    list(POP_FRONT todo l)
    if(l IN_LIST seen)
      continue()
    endif()
    list(APPEND seen ${l})
    if(DEFINED links_${l})
      list(APPEND todo ${links_${l}})
    endif()
  endwhile()
  if("augerd_lib" IN_LIST seen AND NOT dir_${t} IN_LIST allowed_dirs)
    string(APPEND problems "target ${t} (${dir_${t}}) links augerd_lib, augerd's private library\n")
  endif()
endforeach()

# 2. The host's floors, bottom up (docs/daemon.md, issue 14): a host target links only targets
#    of its own floor or below.
set(floor_host 0)             # auger_core (host/src, host/include)
set(floor_host/io 1)          # auger_io
set(floor_host/ros2 2)        # auger_ros2, on io
set(floor_host/ros2_keys 2)   # auger_ros2_keys (auger ros2-keys), on io
set(floor_host/tools 2)       # auger-module
set(floor_host/track 2)       # auger-track
set(floor_host/augerd 3)
set(floor_host/wb_engine 2)     # auger_wb_engine, on the core
set(floor_host/workbench 3)
set(floor_host/operator 3)
set(floor_host/interop 3)
set(floor_host/auger 4)       # the front
foreach(t IN LISTS all_targets)
  set(d ${dir_${t}})
  if(NOT DEFINED floor_${d})
    if(d MATCHES "^host")
      string(APPEND problems "target ${t} (${d}): a host folder without a floor in check_layers.cmake\n")
    endif()
    continue()
  endif()
  foreach(l IN LISTS links_${t})
    if(DEFINED dir_${l} AND DEFINED floor_${dir_${l}})
      if(floor_${dir_${l}} GREATER floor_${d})
        string(APPEND problems "target ${t} (${d}) links ${l} (${dir_${l}}), a floor above it\n")
      endif()
    endif()
  endforeach()
endforeach()

# 3. Includes of augerd's headers outside host/augerd, and of the front's subcommand.hpp below it.
file(GLOB augerd_headers RELATIVE ${SOURCE}/host/augerd ${SOURCE}/host/augerd/*.hpp ${SOURCE}/host/augerd/*.h)
file(GLOB_RECURSE sources RELATIVE ${SOURCE}
     ${SOURCE}/host/*.cpp ${SOURCE}/host/*.hpp ${SOURCE}/host/*.h ${SOURCE}/sim/*.cpp ${SOURCE}/sim/*.hpp
     ${SOURCE}/sim/*.c ${SOURCE}/sim/*.h ${SOURCE}/tests/*.cpp ${SOURCE}/tests/*.hpp ${SOURCE}/bench/*.cpp
     ${SOURCE}/bench/*.c)
foreach(s IN LISTS sources)
  get_filename_component(d ${s} DIRECTORY)
  file(STRINGS ${SOURCE}/${s} incs REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(inc IN LISTS incs)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]*)\".*" "\\1" h "${inc}")
    get_filename_component(hn ${h} NAME)
    if(NOT d IN_LIST allowed_dirs AND (hn IN_LIST augerd_headers OR h MATCHES "augerd/"))
      string(APPEND problems "${s}: includes \"${h}\", a header of augerd (host/augerd)\n")
    endif()
    if(hn STREQUAL "subcommand.hpp" AND NOT d STREQUAL "host/auger")
      string(APPEND problems "${s}: includes the auger front's subcommand.hpp (host/auger), a layer above it\n")
    endif()
  endforeach()
endforeach()

if(problems)
  message(FATAL_ERROR "layering broken (tests/layers/CMakeLists.txt):\n${problems}")
endif()
list(LENGTH all_targets nt)
list(LENGTH sources ns)
message(STATUS "layers: ${nt} targets and ${ns} source files checked")
