"""Schemathesis hooks (tests/api/schemathesis.rs sets SCHEMATHESIS_HOOKS to this module).

openapi.yaml states every rule the server checks that JSON Schema can say (ranges, patterns,
lengths, and in `allOf`/`oneOf` the fields of which exactly one is given). The rules below it
can only say in words, in the descriptions:

- a pose's quaternion is within 1e-3 of unit norm (`PoseValues`);
- an uploaded robot's `urdf` is a URDF document with a serial chain (`RobotUpload`);
- a fixture's three points define a frame: the x-axis point at least 1 mm from the origin, the
  plane point at least 1 mm off that axis (`FixturePoints`);
- a calibration's poses are one place recorded again and again: their spread is a teaching
  noise a cell may have (at most 100 mm, 0.5 rad);
- a trajectory's sample times increase;
- a FANUC `.ls` file begins with its `/PROG` header (an upload is program files);
- a cell's `robot` is an arm the server knows (`GET /v1/robots`): the hooks name a bundled one;
- joints (`joints`, a reach's `near`) are the cell's arm's: one per axis, within its limits
  (the arm is a setting of the cell, known only at run time): the hooks leave them out (they
  are optional everywhere), as a pendant without joint feedback does.

One more hook answers a trait of the fuzzer rather than a rule of the service: its stateful
phase follows links it infers between operations, and when the field a link reads is `null` it
puts the text `None` in a path (`DELETE /v1/waypoints/None`), which the server rightly refuses.
Those cases are dropped.

For the positive cases (the ones the check `positive_data_acceptance` expects the server to
accept) these hooks make the generated bodies follow those rules and change nothing else.
Negative cases are left as generated: the server must refuse them.
"""

import math
import pathlib

import schemathesis

QUATERNION = ("qw", "qx", "qy", "qz")
# A bundled arm: the smallest URDF of the repository.
URDF = (pathlib.Path(__file__).resolve().parents[2] / "robots" / "abb_irb140.urdf").read_text()
MIN_SPREAD_MM = 1.0
A_FRAME = [[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]]


def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def unit_quaternions(value):
    """Normalises every pose's quaternion in `value` (a zero one becomes the identity)."""
    if isinstance(value, dict):
        q = [value.get(k) for k in QUATERNION]
        if all(is_number(c) for c in q):
            norm = math.sqrt(sum(c * c for c in q))
            unit = [1.0, 0.0, 0.0, 0.0] if norm < 1e-9 else [c / norm for c in q]
            value.update(zip(QUATERNION, unit))
        for v in value.values():
            unit_quaternions(v)
    elif isinstance(value, list):
        for v in value:
            unit_quaternions(v)


def defines_a_frame(points):
    """Whether three points define a frame as the server reads them (kinematics/fixture.rs)."""
    if not (isinstance(points, list) and len(points) == 3):
        return False
    if not all(isinstance(p, list) and len(p) == 3 and all(is_number(c) for c in p) for p in points):
        return False
    o, x, xy = points
    ex = [b - a for a, b in zip(o, x)]
    length = math.sqrt(sum(c * c for c in ex))
    if length < MIN_SPREAD_MM:
        return False
    ex = [c / length for c in ex]
    v = [b - a for a, b in zip(o, xy)]
    along = sum(a * b for a, b in zip(v, ex))
    off_axis = math.sqrt(sum((a - along * b) ** 2 for a, b in zip(v, ex)))
    return off_axis >= MIN_SPREAD_MM


def one_place(poses):
    """Calibration poses: the first, recorded again with 0.1 mm between the recordings."""
    first = poses[0]
    for i, pose in enumerate(poses):
        if isinstance(pose, dict) and isinstance(first, dict):
            pose.update(first)
            x = first.get("x")
            if is_number(x):
                pose["x"] = x + 0.1 * i if x < 0 else x - 0.1 * i


def increasing_times(samples):
    """Times that increase: when the generated ones do not, 10 ms apart from 0."""
    times = [s.get("t") if isinstance(s, dict) else None for s in samples]
    if all(is_number(t) for t in times) and all(a < b for a, b in zip(times, times[1:])):
        return
    for i, sample in enumerate(samples):
        if isinstance(sample, dict):
            sample["t"] = 0.01 * i


@schemathesis.hook
def filter_path_parameters(context, path_parameters):
    return not any(v is None for v in (path_parameters or {}).values())


def drop_joints(value):
    """Leaves out every joint vector (`joints`, `near`) in `value`."""
    if isinstance(value, dict):
        for key in ("joints", "near"):
            value.pop(key, None)
        for v in value.values():
            drop_joints(v)
    elif isinstance(value, list):
        for v in value:
            drop_joints(v)


@schemathesis.hook
def map_case(context, case):
    meta = getattr(case, "meta", None)
    if meta is not None and meta.generation.mode.is_negative:
        return case
    body = case.body
    if not isinstance(body, dict):
        return case
    path = case.operation.path
    unit_quaternions(body)
    if isinstance(body.get("urdf"), str):
        body["urdf"] = URDF
    points = body.get("points")
    if isinstance(points, dict):
        for side in ("old", "new"):
            if side in points and not defines_a_frame(points[side]):
                points[side] = [list(p) for p in A_FRAME]
    drop_joints(body)
    settings = body.get("settings")
    if isinstance(settings, dict) and isinstance(settings.get("robot"), str):
        settings["robot"] = "abb_irb140"
    poses = body.get("poses")
    if path.endswith("/calibration") and isinstance(poses, list) and poses:
        one_place(poses)
    samples = body.get("samples")
    if isinstance(samples, list):
        increasing_times(samples)
    files = body.get("files")
    if isinstance(files, list):
        for f in files:
            if not isinstance(f, dict) or not isinstance(f.get("name"), str):
                continue
            text = f.get("content")
            if f["name"].lower().endswith(".ls") and isinstance(text, str):
                if not text.startswith("/PROG"):
                    f["content"] = "/PROG GENERATED\n" + text
    return case
