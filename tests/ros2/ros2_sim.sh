#!/usr/bin/env bash
# augerd's ROS 2 interface against the simulated robot, from an independent DDS participant
# (test_ros2_sim.py in the build venv: Cyclone DDS's Python binding). The simulated robot on
# frozen grass (four modules running the real firmware on ptys), the real augerd with [ros2]
# enabled in namespace /robot1 on a domain id of this run, DDS on loopback only; the simulated
# camera and IMU are *not* connected (the test is the camera and IMU, through DDS).
# Usage: ros2_sim.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
py=$build/venv/bin/python3
[[ -x $py ]] || { echo "ros2_sim: $py is missing: run make venv" >&2; exit 1; }
work=$(mktemp -d /tmp/auger-ros2-XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "ros2_sim: $*" >&2; for f in "$work"/*.out; do echo "--- $f" >&2; tail -8 "$f" >&2; done; exit 1; }

# A domain id per run (1..232 but the ROS default 0), so that parallel runs never meet.
export ROS2_DOMAIN=$(( ($$ % 200) + 20 ))
export CYCLONEDDS_URI=file://$src/tests/ros2/dds-loopback.xml
export ROS2_NS=/robot1 ROS2_CMD_VEL=cmd_vel ROS2_CMD_VEL_STAMPED=cmd_vel_stamped ROS2_POSE=/camera/pose \
  ROS2_POSE_COV=pose_cov ROS2_IMU=imu/data ROS2_ODOM=odom ROS2_JOINTS=joint_states

AUGER_BUILD=$build AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_start "$work" frozen_grass 60 || fail "the simulated robot did not start"
pids+=("$SIM_PID")
AUGERD_SENSORS_SOCKET=$work/augerd-sensors.sock augerd_start "$work" frozen_grass "" "" "[ros2]
enabled = true
domain_id = $ROS2_DOMAIN
dds_config = \"$src/tests/ros2/dds-loopback.xml\"
namespace = \"$ROS2_NS\"
cmd_vel_topic = \"$ROS2_CMD_VEL\"
cmd_vel_stamped_topic = \"$ROS2_CMD_VEL_STAMPED\"
pose_topic = \"$ROS2_POSE\"
pose_cov_topic = \"$ROS2_POSE_COV\"
imu_topic = \"$ROS2_IMU\"" || fail "augerd did not start"
augerd_pid=$AUGERD_PID
pids+=("$augerd_pid")
grep -q "ROS 2 on DDS, domain $ROS2_DOMAIN" "$work/augerd.out" || fail "augerd does not report its ROS 2 interface"

export AUGER=$build/host/auger/auger AUGERD_SOCKET=$work/commands.sock
cd "$src/tests/ros2"
"$py" -m pytest -q -s -p no:cacheprovider test_ros2_sim.py || fail "test_ros2_sim.py failed"
kill -TERM "$augerd_pid"
wait "$augerd_pid" || true
# augerd's own measurement of the loop's time in the bridge (docs/benchmarks.md).
grep "ROS 2:.*per cycle" "$work/augerd.out" || fail "augerd did not report the bridge's time"
grep "loop period" "$work/augerd.out"
