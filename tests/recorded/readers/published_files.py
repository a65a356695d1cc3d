"""Files in the published formats (raw NGSIM, levelX/highD, INTERACTION, a CATS-like
shipped sample), written by the readers' tests: a few synthetic vehicles each.

No licensed data is in the repository: every test writes its files in the published
layout and checks the road frame in closed form (x along travel, y to the left, lane 0
rightmost, centres, SI units).
"""

import numpy as np
import pandas as pd

from drivestyle.recorded.readers import NGSIM_COLUMNS

FT = 0.3048
T0_MS = 1_118_846_980_000  # an NGSIM-like epoch time stamp [ms]


def _smoothstep(s):
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s), 6 * s * (1 - s)


def _track(pick, vid):
    [track] = [t for t in pick.tracks if t.vehicle_id == vid]
    return track


# ------------------------------------------------------------------------------------ NGSIM
LANE_X_FT = {1: 6.0, 2: 18.0, 3: 30.0, 4: 42.0, 5: 54.0, 6: 66.0}
"""Lane centres' Local_X [ft]: 12 ft lanes from the left road edge."""


def _ngsim_vehicle(
    vid, frames, local_x, lane_id, y0=100.0, vel=50.0, length=15.0, width=6.0, t0_ms=T0_MS
):
    frames = np.asarray(frames)
    n = frames.size
    local_y = y0 + vel * 0.1 * (frames - frames[0])
    return pd.DataFrame(
        {
            "Vehicle_ID": vid,
            "Frame_ID": frames,
            "Total_Frames": n,
            "Global_Time": t0_ms + 100 * frames,
            "Local_X": np.broadcast_to(local_x, n),
            "Local_Y": local_y,
            "Global_X": 6_451_000.0 + local_y,
            "Global_Y": 1_873_000.0 + np.broadcast_to(local_x, n),
            "v_Length": length,
            "v_Width": width,
            "v_Class": 2,
            "v_Vel": vel,
            "v_Acc": 0.0,
            "Lane_ID": np.broadcast_to(lane_id, n),
            "Preceding": 0,
            "Following": 0,
            "Space_Headway": 0.0,
            "Time_Headway": 0.0,
        }
    )


def _lane_change(from_lane, to_lane, n=20, cross=(8, 12)):
    """Local_X [ft] and Lane_ID of a lane change: at the centre, a quick cross, the centre."""
    a, b = LANE_X_FT[from_lane], LANE_X_FT[to_lane]
    s, _ = _smoothstep((np.arange(n) - cross[0] + 1) / (cross[1] - cross[0] + 1))
    x = a + (b - a) * s
    lane = np.where(np.abs(x - a) < np.abs(x - b), from_lane, to_lane)
    return x, lane


def _ngsim_table():
    frames = np.arange(10, 30)
    left_x, left_lane = _lane_change(3, 2)  # toward lane 1: the driver's left
    right_x, right_lane = _lane_change(4, 5)
    return pd.concat(
        [
            _ngsim_vehicle(1, frames, LANE_X_FT[2], 2),
            _ngsim_vehicle(2, frames, left_x, left_lane, y0=200.0),
            _ngsim_vehicle(3, frames, right_x, right_lane, y0=300.0),
            _ngsim_vehicle(4, frames, LANE_X_FT[1], 1, y0=150.0),
            _ngsim_vehicle(5, frames, LANE_X_FT[5], 5, y0=250.0),
            _ngsim_vehicle(6, frames + 5, LANE_X_FT[6], 6, y0=50.0, length=40.0, width=8.5),
        ],
        ignore_index=True,
    )


def _write_classic(df, path):
    """The classic text layout: the 18 columns, whitespace separated, no header."""
    df = df[list(NGSIM_COLUMNS)]
    path.write_text(
        "\n".join("   ".join(f"{v:.15g}" for v in row) for row in df.to_numpy(float)) + "\n"
    )
    return path


def _one_line(err, *parts):
    msg = str(err.value)
    assert "\n" not in msg, msg
    for p in parts:
        assert p in msg, (p, msg)


# ----------------------------------------------------------------------------------- levelX
UPPER = (13.0, 16.5, 20.0, 23.5)
"""Image y of the upper (−x) carriageway's lane lines [m]: its right edge is at the top."""
LOWER = (27.0, 30.5, 34.0, 37.5)
"""Image y of the lower (+x) carriageway's lane lines [m]: its right edge is at the bottom."""
RATE = 25.0


def _levelx_vehicle(vid, x0, y_from, y_to, vx, n=50, w=4.5, h=1.8):
    """Rows of one vehicle: box corner from (x0, y_from) at speed vx, moving to y_to."""
    frame = np.arange(1, n + 1) + 10 * vid
    tau = (frame - frame[0]) / RATE
    s, ds = _smoothstep((tau - 0.4) / 1.2)
    return pd.DataFrame(
        {
            "frame": frame,
            "id": vid,
            "x": x0 + vx * tau,
            "y": y_from + (y_to - y_from) * s,
            "width": w,
            "height": h,
            "xVelocity": vx,
            "yVelocity": (y_to - y_from) * ds / 1.2,
            "xAcceleration": 0.0,
            "yAcceleration": 0.0,
            "laneId": 0,
        }
    )


def _write_levelx(tmp_path, vehicles, directions, nn="01"):
    pd.concat(vehicles, ignore_index=True).to_csv(tmp_path / f"{nn}_tracks.csv", index=False)
    pd.DataFrame(
        {"id": list(directions), "drivingDirection": list(directions.values()), "class": "Car"}
    ).to_csv(tmp_path / f"{nn}_tracksMeta.csv", index=False)
    pd.DataFrame(
        {
            "id": [int(nn)],
            "frameRate": [RATE],
            "upperLaneMarkings": [";".join(map(str, UPPER))],
            "lowerLaneMarkings": [";".join(map(str, LOWER))],
        }
    ).to_csv(tmp_path / f"{nn}_recordingMeta.csv", index=False)
    return tmp_path / f"{nn}_tracks.csv"


def _levelx_files(tmp_path):
    # box corners y = lane centre − h/2; upper centres 14.75, 18.25, 21.75; lower 28.75, …
    vehicles = [
        _levelx_vehicle(1, 100.0, 20.0, 20.0, -30.0),  # upper, straight: the closed-form one
        _levelx_vehicle(2, 300.0, 17.35, 20.85, -28.0),  # upper, image +y: its left
        _levelx_vehicle(3, 320.0, 17.35, 13.85, -28.0),  # upper, image −y: its right
        _levelx_vehicle(4, 10.0, 31.35, 27.85, 25.0),  # lower, image −y: its left
        _levelx_vehicle(5, 30.0, 31.35, 34.85, 25.0),  # lower, image +y: its right
    ]
    return _write_levelx(tmp_path, vehicles, {1: 1, 2: 1, 3: 1, 4: 2, 5: 2})


# ------------------------------------------------------------------------------ INTERACTION
def _interaction_vehicle(case, track, p0, velocity, lateral, n=30, agent="car", psi=None):
    """Rows of one agent at p0 + velocity·t + lateral·s(t) (map frame, 10 Hz)."""
    frame = np.arange(1, n + 1)
    t = (frame - 1) * 0.1
    s, ds = _smoothstep((t - 0.8) / 1.2)
    pos = np.asarray(p0) + np.outer(t, velocity) + np.outer(s, lateral)
    vel = np.asarray(velocity) + np.outer(ds / 1.2, lateral)
    return pd.DataFrame(
        {
            "case_id": float(case),
            "track_id": track,
            "frame_id": frame,
            "timestamp_ms": 100 * frame,
            "agent_type": agent,
            "x": pos[:, 0],
            "y": pos[:, 1],
            "vx": vel[:, 0],
            "vy": vel[:, 1],
            "psi_rad": np.arctan2(vel[:, 1], vel[:, 0]) if psi is None else psi,
            "length": 4.8,
            "width": 1.9,
        }
    )


# --------------------------------------------------------------------------- shipped sample
def _cats_sample(folder, **changes):
    """A shipped-sample folder in the CATS layout: two vehicles, 10 Hz, 12 s."""
    t = np.round(np.arange(0, 12.0 + 1e-9, 0.1), 9)
    rows = pd.concat(
        [
            pd.DataFrame(
                {
                    "run_id": "run",
                    "vehicle_id": v,
                    "t_s": t,
                    "x_m": x0 + 25.0 * t,
                    "y_m": y,
                    "v_mps": 25.0,
                    "lane": lane,
                }
            )
            for v, x0, y, lane in ((1, 0.0, 2.0, 0), (2, 40.0, 6.0, 1))
        ],
        ignore_index=True,
    )
    for column, change in changes.items():
        rows[column] = change(rows[column])
    folder.mkdir()
    rows.to_csv(folder / "tracks.csv.gz", index=False)
    return folder
