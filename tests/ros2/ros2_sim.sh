#!/usr/bin/env bash
# augerd's ROS 2 interface against the simulated robot, from independent DDS participants. The
# simulated robot on frozen grass (four modules running the real firmware on ptys), the real
# augerd with [ros2] enabled in namespace /robot1 on a domain id of this run, DDS on loopback
# only; the simulated camera and IMU are *not* connected (the tests are the camera and IMU,
# through DDS). One of three test files runs against it, in the build venv (Cyclone DDS's Python
# binding):
#   sim      test_ros2_sim.py: names, QoS, outputs, inputs, arbitration (without DDS Security)
#   hostile  test_ros2_hostile.py: peers announcing mismatched types on every topic, the loop's
#            period meanwhile (without DDS Security)
#   secure   test_ros2_secure.py: augerd with a keystore of `auger ros2-keys` (made here, with
#            two peers' enclaves and a rogue keystore), peers with and without keys
# Usage: ros2_sim.sh BUILD_DIR SOURCE_DIR [sim|hostile|secure]
set -euo pipefail
build=$1 src=$2 mode=${3:-sim}
py=$build/venv/bin/python3
[[ -x $py ]] || { echo "ros2_sim: $py is missing: run make venv" >&2; exit 1; }
[[ $mode == sim || $mode == hostile || $mode == secure ]] || { echo "ros2_sim: unknown mode $mode" >&2; exit 2; }
work=$(mktemp -d /tmp/auger-ros2-XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "ros2_sim ($mode): $*" >&2; for f in "$work"/*.out; do echo "--- $f" >&2; tail -8 "$f" >&2; done; exit 1; }

# A domain id per run (1..232 but the ROS default 0), so that parallel runs never meet.
export ROS2_DOMAIN=$(( ($$ % 200) + 20 ))
export CYCLONEDDS_URI=file://$src/tests/ros2/dds-loopback.xml ROS2_DDS_CONFIG=$src/tests/ros2/dds-loopback.xml
export ROS2_NS=/robot1 ROS2_CMD_VEL=cmd_vel ROS2_CMD_VEL_STAMPED=cmd_vel_stamped ROS2_POSE=/camera/pose \
  ROS2_POSE_COV=pose_cov ROS2_IMU=imu/data ROS2_ODOM=odom ROS2_JOINTS=joint_states ROS2_LOCAL_PRIORITY_S=1.0 \
  ROS2_ONLINE=online_estimate
export AUGER=$build/host/auger/auger AUGERD_SOCKET=$work/commands.sock AUGERD_LOG_DIR=$work/logs
# These tests are of the ROS 2 interface, not of the serial watchdog (test_daemon's): the
# simulated modules run in real time beside the other tests, and one stall of the simulator of
# 112 ms under -j2 once stopped every screw mid-test (no telemetry for 112 ms). The
# configuration's longest timeout keeps that from looking like a ROS 2 failure.
export AUGERD_TELEMETRY_TIMEOUT_S=0.25

AUGER_BUILD=$build AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_start "$work" frozen_grass 60 || fail "the simulated robot did not start"
pids+=("$SIM_PID")
ros2="[ros2]
enabled = true
domain_id = $ROS2_DOMAIN
dds_config = \"$ROS2_DDS_CONFIG\"
namespace = \"$ROS2_NS\"
cmd_vel_topic = \"$ROS2_CMD_VEL\"
cmd_vel_stamped_topic = \"$ROS2_CMD_VEL_STAMPED\"
pose_topic = \"$ROS2_POSE\"
pose_cov_topic = \"$ROS2_POSE_COV\"
imu_topic = \"$ROS2_IMU\"
local_priority_s = $ROS2_LOCAL_PRIORITY_S"
if [[ $mode == secure ]]; then
  # The keystore as a user makes it (docs/ros2.md): augerd's, an operator's and a read-only
  # viewer's enclaves; and a second keystore, whose CA augerd does not trust, with an operator.
  export ROS2_KEYSTORE=$work/keys ROS2_ROGUE=$work/rogue ROS2_PEER=$build/tests/ros2/ros2_secure_peer
  AUGERD_SENSORS_SOCKET=$work/augerd-sensors.sock augerd_config "$work" frozen_grass "" "" "$ros2"
  for args in "create $ROS2_KEYSTORE" "peer $ROS2_KEYSTORE operator" "peer $ROS2_KEYSTORE viewer --read-only" \
              "create $ROS2_ROGUE" "peer $ROS2_ROGUE operator"; do
    # shellcheck disable=SC2086 # the words of args are the arguments
    "$AUGER" ros2-keys $args --config "$work/augerd.toml" > "$work/keys.out" 2>&1 ||
      fail "auger ros2-keys $args failed: $(cat "$work/keys.out")"
  done
  ros2+="
keystore = \"$ROS2_KEYSTORE\""
else
  ros2+="
insecure = true"
fi
if [[ $mode == sim ]]; then
  # augerd's online estimator (docs/daemon.md), for its diagnostics entry and estimate topic.
  ros2+="
[online]
enabled = true"
fi
AUGERD_SENSORS_SOCKET=$work/augerd-sensors.sock augerd_start "$work" frozen_grass "" "" "$ros2" ||
  fail "augerd did not start"
augerd_pid=$AUGERD_PID
pids+=("$augerd_pid")
export AUGERD_PID=$augerd_pid
grep -q "ROS 2 on DDS, domain $ROS2_DOMAIN" "$work/augerd.out" || fail "augerd does not report its ROS 2 interface"

cd "$src/tests/ros2"
"$py" -m pytest -q -s -p no:cacheprovider "test_ros2_$mode.py" || fail "test_ros2_$mode.py failed"
kill -0 "$augerd_pid" || fail "augerd died"
kill -TERM "$augerd_pid"
wait "$augerd_pid" || fail "augerd exited with $?"
# augerd's own measurement of the loop's time in the bridge (docs/benchmarks.md).
grep "ROS 2:.*per cycle" "$work/augerd.out" || fail "augerd did not report the bridge's time"
grep "loop period" "$work/augerd.out"
