#!/usr/bin/env python3
"""Writes the malformed-input corpus of tests/data/malformed/ (issue #16).

Every file is small and synthetic: a 6 m x 4 m room seen by a 91-beam (2-degree) laser from
near its centre, then broken in one way. Run from anywhere; the files land next to this
script. The expected outcome of each file is in MANIFEST.txt (checked by
tests/malformed/run_corpus.sh).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def room_ranges(n=91, angle_min=-math.pi / 2, increment=math.pi / 90, x=0.0):
    """Ranges from (x, 0) to the walls of the room [-3, 3] x [-2, 2]."""
    out = []
    for i in range(n):
        a = angle_min + i * increment
        c, s = math.cos(a), math.sin(a)
        t = 1e9
        if abs(c) > 1e-9:
            for wx in (-3.0, 3.0):
                tt = (wx - x) / c
                if tt > 0:
                    t = min(t, tt)
        if abs(s) > 1e-9:
            for wy in (-2.0, 2.0):
                tt = wy / s
                if tt > 0:
                    t = min(t, tt)
        out.append("%.3f" % t)
    return out


def laser(stamp, n=91, angle_min=-math.pi / 2, increment=math.pi / 90, x=0.0, ranges=None):
    r = ranges if ranges is not None else room_ranges(n, angle_min, increment, x)
    return "LASER %s %d %.6f %.8f 0.05 30 %s" % (stamp, n, angle_min, increment, " ".join(r))


def flaser(stamp, x=0.0, n=181, ranges=None, odom_x=None):
    r = ranges if ranges is not None else room_ranges(n, -math.pi / 2, math.pi / 180, 0.0)
    ox = x if odom_x is None else odom_x
    return "FLASER %d %s %s 0 0 %s 0 0 %s robot %s" % (n, " ".join(r), x, ox, stamp, stamp)


def write(name, lines, ending="\n", binary=None):
    path = os.path.join(HERE, name)
    with open(path, "wb") as f:
        if binary is not None:
            f.write(binary)
        else:
            f.write((ending.join(lines) + (ending if lines else "")).encode())


def scans(stamps, **kw):
    return [laser(s, **kw) for s in stamps]


def main():
    five = ["%.1f" % (0.1 * k) for k in range(1, 6)]
    # --- hetslam robot logs -------------------------------------------------------------
    write("robot_ok.txt", ["HSLOG 1", "COMMAND 0 0 0 0"] + scans(five) + ["TRUTH %s 0 0 0 0 0 0" % s for s in five])
    write("robot_stamp_1e20.txt", ["HSLOG 1", "COMMAND 0 0 0 0"] + scans(five) + [laser("1e20")])
    write("robot_gap_10h.txt", ["HSLOG 1", "COMMAND 0 0.3 0 0"] + scans(five) + [laser("36000.5")])
    write("robot_stamp_jump_1e11.txt", ["HSLOG 1"] + scans(five) + [laser("1e11")] + scans(["0.6", "0.7"]))
    write("robot_scan_before_command.txt",
          ["HSLOG 1", "COMMAND 1 0.1 0 0"] + scans(["1.5", "1.6", "1.7", "1.8", "1.9"]) + [laser("0.5")])
    write("robot_command_huge.txt", ["HSLOG 1", "COMMAND 0 1e12 0 0"] + scans(five))
    write("robot_odom_jump.txt", ["HSLOG 1", "ODOM 0 0 0 0", "ODOM 0.35 9e6 0 0"] + scans(five))
    write("robot_angle_zero.txt", ["HSLOG 1"] + scans(five, increment=0.0))
    write("robot_angle_absurd.txt", ["HSLOG 1"] + scans(five[:3]) + [laser("0.4", increment=1e300)])
    write("robot_angle_min_huge.txt", ["HSLOG 1", laser("0.1", angle_min=1e6)])
    write("robot_nan_ranges.txt", ["HSLOG 1"] + scans(five[:4]) +
          [laser("0.5", ranges=["nan"] * 30 + ["inf"] * 30 + ["-1"] * 31)])
    write("robot_beam_count_disagrees.txt", ["HSLOG 1", laser("0.1").replace("LASER 0.1 91 ", "LASER 0.1 95 ", 1)])
    write("robot_beam_count_huge.txt", ["HSLOG 1", "LASER 0.1 100000000 0 0.01 0.05 30 1 2 3"])
    write("robot_truncated.txt", ["HSLOG 1", laser("0.1")[:300]])
    write("robot_all_backwards.txt", ["HSLOG 1"] + scans(["0.5", "0.4", "0.3", "0.2", "0.1"]) +
          ["TRUTH 0.5 0 0 0 0 0 0", "TRUTH 0.6 0 0 0 0 0 0"])
    write("robot_all_equal_stamps.txt", ["HSLOG 1"] + scans(["7"] * 5))
    write("robot_all_zero_stamps.txt", ["HSLOG 1"] + scans(["0"] * 5))
    write("robot_image_traversal.txt", ["HSLOG 1", "IMAGE 0.1 ../../../../etc/passwd"] + scans(five))
    write("robot_no_header.txt", scans(five))
    write("robot_crlf.txt", ["HSLOG 1"] + scans(five), ending="\r\n")
    write("robot_cr_only.txt", ["HSLOG 1"] + scans(five), ending="\r")
    write("robot_lenient_mixed.txt", ["HSLOG 1", "LASER 0.05 3 0 0 0 10 1 2 3", "FOO 1"] + scans(five))
    # Degenerate worlds: nothing in range, a single wall, one scan per hour.
    write("robot_all_max_range.txt", ["HSLOG 1"] + scans(five, ranges=["30"] * 91))
    wall = ["%.3f" % (2.0 / math.cos(-math.pi / 4 + i * math.pi / 180)) for i in range(91)]
    write("robot_single_wall.txt", ["HSLOG 1"] + scans(five, angle_min=-math.pi / 4, increment=math.pi / 180, ranges=wall))
    write("robot_scan_per_hour.txt", ["HSLOG 1"] + scans(["%d" % (3600 * k) for k in range(5)]))
    # --- CARMEN logs ----------------------------------------------------------------------
    stamps = ["%.1f" % (1000 + 0.1 * k) for k in range(6)]
    write("carmen_ok.clf", [flaser(s) for s in stamps])
    write("carmen_empty.clf", [])
    write("carmen_binary.clf", [], binary=bytes((i * 37 + 11) % 256 for i in range(2048)))
    write("carmen_truncated.clf", [flaser(s) for s in stamps[:3]] + [flaser(stamps[3])[:200]])
    write("carmen_beam_count_disagrees.clf", [flaser(stamps[0]).replace("FLASER 181 ", "FLASER 190 ", 1)])
    write("carmen_nan_inf_negative.clf", [flaser(s) for s in stamps[:5]] +
          [flaser(stamps[5], ranges=["nan"] * 60 + ["inf"] * 60 + ["-2"] * 61)])
    write("carmen_backwards.clf", [flaser(s) for s in reversed(stamps)])
    write("carmen_all_equal.clf", [flaser("1000.0") for _ in stamps])
    write("carmen_all_zero.clf", [flaser("0") for _ in stamps])
    write("carmen_jump_1e15.clf", [flaser(s) for s in stamps] + [flaser("1e15")])
    write("carmen_position_huge.clf", [flaser(s) for s in stamps[:5]] + [flaser(stamps[5], x="1e300")])
    write("carmen_odom_jump.clf", [flaser(s) for s in stamps[:5]] + [flaser(stamps[5], x="9e6")] + [flaser("1000.6")])
    write("carmen_crlf.clf", [flaser(s) for s in stamps], ending="\r\n")
    write("carmen_robotlaser_angle.clf",
          ["ROBOTLASER1 0 -1.5708 3.14159 0 81.9 0.01 0 3 1 2 3 0 0 0 0 0 0 0 0 0 0 0 0 1000.0 robot 1000.0"])
    # --- pose graphs ----------------------------------------------------------------------
    v = ["VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1 0 0", "VERTEX_SE2 2 2 0 0"]
    write("g2o_ok.g2o", v + ["EDGE_SE2 0 1 1 0 0 100 0 0 100 0 1000", "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 1000",
                             "EDGE_SE2 0 2 2 0 0 100 0 0 100 0 1000", "FIX 0"])
    write("g2o_info_nan.g2o", v + ["EDGE_SE2 0 1 1 0 0 nan 0 0 1 0 1"])
    write("g2o_info_huge.g2o", v + ["EDGE_SE2 0 1 1 0 0 1e308 1e308 1e308 1e308 1e308 1e308"])
    write("g2o_info_not_pd.g2o", v + ["EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1"])
    write("g2o_vertex_huge.g2o", ["VERTEX_SE2 0 1e300 0 0", "VERTEX_SE2 1 0 0 0"])
    write("g2o_self_edge.g2o", v + ["EDGE_SE2 1 1 1 0 0 1 0 0 1 0 1"])
    write("g2o_dangling.g2o", v + ["EDGE_SE2 0 9 1 0 0 1 0 0 1 0 1"])
    # --- trajectories and relations -------------------------------------------------------
    traj = ["%.1f %.2f 0 0" % (k * 0.5, k * 0.1) for k in range(12)]
    write("trajectory_ok.txt", traj)
    write("trajectory_duplicated_rows.txt", [r for row in traj for r in (row, row)])
    write("trajectory_backwards.txt", list(reversed(traj)))
    write("trajectory_nan.txt", traj[:3] + ["1.5 nan 0 0"] + traj[4:])
    write("relations_ok.txt", ["%.1f %.1f 0.1 0 0 0 0 0" % (k * 0.5, (k + 1) * 0.5) for k in range(10)])
    write("relations_short_line.txt", ["0.0 0.5 0.1 0 0 0 0"])
    write("relations_inf.txt", ["0.0 inf 0.1 0 0 0 0 0"])
    # --- team manifests -------------------------------------------------------------------
    write("team_traversal.txt", ["HSTEAM 1", "robot x uav ../../../../etc"])
    write("team_absolute.txt", ["HSTEAM 1", "robot x uav /etc"])
    write("team_missing_robot_dir.txt", ["HSTEAM 1", "robot x uav no_such_robot"])
    # --- scenarios ------------------------------------------------------------------------
    room = ["wall 0 0 4 0", "wall 4 0 4 4", "wall 4 4 0 4", "wall 0 4 0 0"]
    route = ["waypoint 1 1", "waypoint 3 1"]
    write("scenario_ok.scenario", room + route + ["duration_limit_s 20"])
    write("scenario_box_degenerate.scenario", room + ["box 1e5 1e5 1e-9 1e-9"] + route)
    write("scenario_long_wall.scenario", room + ["wall 0 -1 900000 -1"] + route)
    write("scenario_duration_1e300.scenario", room + route + ["duration_limit_s 1e300"])
    write("scenario_beams_budget.scenario", room + route + ["laser 360 100000 30 0.01 0 1000",
                                                             "duration_limit_s 86400"])
    write("scenario_prism_degenerate.scenario", room + ["obstacle 1e5 1e5 1e-9 1e-9 1"] + route)


if __name__ == "__main__":
    main()
