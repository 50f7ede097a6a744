# Did the simulated robot arrive? Reads the simulator's truth log (robot-log format, true pose
# in x_m, y_m) and augerd's `status` answer (-v s="..."), goal (-v gx= -v gy=), the test's name
# (-v name=). Passes (exit 0) when the last true pose is within 0.03 m of the goal, augerd's
# estimate within 0.03 m of the truth, no fault, and still enabled.
/^#/ { next }
!hdr { for (i = 1; i <= NF; i++) col[$i] = i; hdr = 1; next }
{ x = $col["x_m"]; y = $col["y_m"] }
END {
  n = split(s, f, " ")
  for (i = 1; i <= n; i++) { split(f[i], kv, "="); v[kv[1]] = kv[2] }
  err = sqrt((x - gx) ^ 2 + (y - gy) ^ 2)
  est = sqrt((v["x_m"] - x) ^ 2 + (v["y_m"] - y) ^ 2)
  printf "%s: true pose %.3f m from the goal, estimate %.3f m from the truth, fault=%s\n", name, err, est, v["fault"]
  exit !(hdr && err < 0.03 && est < 0.03 && v["fault"] == "none" && v["enabled"] == 1)
}
