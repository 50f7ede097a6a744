# The layering check's self test: cmake -DCHECK=check_layers.cmake -DWORK=<scratch folder> -P this.
cmake_minimum_required(VERSION 3.25)
# A small tree laid out like auger's passes the check; each case breaks one wall in it (a link
# or an include) and the check must fail naming that target or file and line.

set(clean_rows
  "auger_protocol|.|"
  "auger_fw_logic|firmware|auger_protocol"
  "auger_core|host|Eigen3::Eigen"
  "auger_io|host/io|auger_core,auger_protocol"
  "auger_wb_engine|host/wb_engine|auger_core,nlohmann_json::nlohmann_json"
  "auger_workbench|host/workbench|auger_wb_engine,auger_io"
  "auger_operator|host/operator|auger_core,auger_io"
  "augerd_lib|host/augerd|auger_core,auger_io,Threads::Threads"
  "augerd|host/augerd|augerd_lib"
  "auger|host/auger|auger_workbench,auger_operator,auger_io"
  "auger_simmodels|sim|m"
  "auger_simmod|sim|auger_simmodels,Threads::Threads"
  "auger_robotsim|sim/robot|auger_core,auger_simmod,auger_protocol,auger_io"
  "auger_fil_rig|sim/rig|auger_simmod,auger_protocol,auger_operator"
  "fw_bench|bench|auger_fil_rig,auger_simmod"
  "robot_speed|bench|auger_robotsim,auger_core"
  "auger_catch_main|tests|Catch2::Catch2"
  "auger_test_vectors|tests/protocol|auger_protocol"
  "test_fil|tests/fil|auger_catch_main,auger_fil_rig,auger_test_vectors"
  "test_daemon_unit|tests/daemon|auger_catch_main,augerd_lib"
  "test_robot_unit|tests/robot|auger_catch_main,auger_robotsim")
# file -> its text; a header of each area, and sources that include across the allowed walls.
set(clean_files
  "shared/protocol.h=// frames"
  "host/include/auger/model.hpp=// the model"
  "host/augerd/daemon.hpp=// augerd"
  "host/workbench/fit.cpp=#include \"auger/model.hpp\""
  "sim/simmod.h=// the modules"
  "sim/robot/true_robot.hpp=#include \"auger/model.hpp\""
  "sim/rig/fil_rig.hpp=#include \"simmod.h\"\n#include \"protocol.h\""
  "bench/fw_bench.cpp=// the bench\n#include \"fil_rig.hpp\""
  "tests/support/golden_vectors.hpp=#include \"protocol.h\""
  "tests/fil/test_fil.cpp=#include \"fil_rig.hpp\"\n#include \"golden_vectors.hpp\""
  "tests/daemon/test_daemon_unit.cpp=#include \"daemon.hpp\"")

set(failures "")
# Runs the check on the clean tree changed by `rows` (replacing rows of the same target, or
# added) and `files` (the same), and compares the outcome with `expect` ("" = passes, else a
# regular expression the error must match).
function(run_case name rows files expect)
  set(dir ${WORK}/${name})
  file(REMOVE_RECURSE ${dir})
  set(all_rows ${clean_rows})
  foreach(r IN LISTS rows)
    string(REGEX REPLACE "\\|.*" "" t "${r}")
    list(FILTER all_rows EXCLUDE REGEX "^${t}\\|")
    list(APPEND all_rows "${r}")
  endforeach()
  list(JOIN all_rows "\n" text)
  file(WRITE ${dir}/layers.txt "${text}\n")
  foreach(entry IN LISTS clean_files files)
    string(REGEX REPLACE "=.*" "" path "${entry}")
    string(REGEX REPLACE "^[^=]*=" "" body "${entry}")
    string(REPLACE "\\n" "\n" body "${body}")
    file(WRITE ${dir}/src/${path} "${body}\n")
  endforeach()
  execute_process(COMMAND ${CMAKE_COMMAND} -DLAYERS=${dir}/layers.txt -DSOURCE=${dir}/src -P ${CHECK}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect STREQUAL "")
    if(NOT rc EQUAL 0)
      set(failures "${failures}${name}: the clean tree failed:\n${err}\n" PARENT_SCOPE)
    endif()
  elseif(rc EQUAL 0)
    set(failures "${failures}${name}: passed, expected a failure matching ${expect}\n" PARENT_SCOPE)
  else()
    # message(FATAL_ERROR) wraps its text at spaces: compare with the spaces folded.
    string(REGEX REPLACE "[ \t\n]+" " " flat "${err}")
    if(NOT flat MATCHES "${expect}")
      set(failures "${failures}${name}: failed without naming the problem (${expect}):\n${err}\n" PARENT_SCOPE)
    endif()
  endif()
endfunction()

run_case(clean "" "" "")
# The workbench on the simulated robot's physics, through its engine.
run_case(workbench_physics "auger_wb_engine|host/wb_engine|auger_core,auger_robotsim" ""
  "target auger_workbench \\(host/workbench\\) links auger_robotsim \\(sim/robot\\) through auger_wb_engine: the simulator")
# augerd on the simulated modules.
run_case(augerd_modules "augerd_lib|host/augerd|auger_core,auger_io,auger_simmod" ""
  "target augerd \\(host/augerd\\) links auger_simmod \\(sim\\) through augerd_lib: the simulator")
# The front on the modules' physics, two links down.
run_case(auger_simmodels "auger_operator|host/operator|auger_core,auger_io,auger_simmod" ""
  "target auger \\(host/auger\\) links auger_simmodels \\(sim\\) through auger_operator -> auger_simmod")
# A host tool on a library of the tests.
run_case(host_tests "auger_io|host/io|auger_core,auger_protocol,auger_test_vectors" ""
  "target auger_io \\(host/io\\) links auger_test_vectors \\(tests/protocol\\): the simulator, the bench or the tests")
# The bench on a library of the tests.
run_case(bench_links_tests "robot_speed|bench|auger_robotsim,auger_test_vectors" ""
  "target robot_speed \\(bench, floor 5\\) links auger_test_vectors \\(tests/protocol, floor 6\\), a floor above it")
# The simulated robot on a floor above it.
run_case(sim_floor "auger_robotsim|sim/robot|auger_core,auger_simmod,auger_workbench" ""
  "target auger_robotsim \\(sim/robot, floor 2\\) links auger_workbench \\(host/workbench, floor 3\\)")
# The bench includes a header of the tests (line 2).
run_case(bench_includes_tests "" "bench/fw_bench.cpp=// the bench\\n#include \"golden_vectors.hpp\""
  "bench/fw_bench.cpp:2: includes \"golden_vectors.hpp\", a header of the tests \\(tests/support/golden_vectors.hpp\\)")
# The workbench includes the simulated robot's header.
run_case(host_includes_sim "" "host/workbench/fit.cpp=#include \"auger/model.hpp\"\\n#include \"true_robot.hpp\""
  "host/workbench/fit.cpp:2: includes \"true_robot.hpp\", a header of the simulator, the bench or the tests \\(sim/robot/true_robot.hpp\\)")
# A folder nobody gave a floor.
run_case(no_floor "auger_new|host/new|auger_core" ""
  "target auger_new \\(host/new\\): a folder without a floor")
# The rules the check had before: augerd's private library and headers.
run_case(augerd_lib "auger_workbench|host/workbench|auger_wb_engine,augerd_lib" ""
  "target auger_workbench \\(host/workbench\\) links augerd_lib \\(host/augerd\\): augerd's private library")
run_case(augerd_header "" "host/workbench/fit.cpp=#include \"daemon.hpp\""
  "host/workbench/fit.cpp:1: includes \"daemon.hpp\", a header of augerd")

if(failures)
  message(FATAL_ERROR "the layering check missed:\n${failures}")
endif()
message(STATUS "layers self test: the clean tree passes, 11 broken ones fail")
