"""The report's 3D view, Python side (mrnea.report.view3d, view3d_html, shapes), against
independent references: closed forms (quaternions of axis-angle rotations, capsule ends, axes
rectangles, a two-link arm's frames), brute force (pooled flags) and the page's own decoding
written out in NumPy. The frames come from mrnea.forward_kinematics, checked against Pinocchio in
its own tests. The browser side is tests/test_report_browser.py.
"""

from __future__ import annotations

import base64
import gzip
import json
import re
import warnings

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from mrnea.model import Joint, Link, Robot
from mrnea.report import shapes as shp
from mrnea.report import view3d, view3d_html
from mrnea.rigid import transform
from mrnea.visual import Visual


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix."""
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def random_frames(F: int, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    T = np.zeros((F, n, 4, 4))
    T[..., 3, 3] = 1
    for k in range(F):
        for i in range(n):
            T[k, i, :3, :3] = axis_angle(rng.normal(size=3), rng.uniform(-np.pi, np.pi))
            T[k, i, :3, 3] = rng.uniform(-2, 3, 3)
    return T


def test_quaternions_match_the_axis_angle_closed_form() -> None:
    rng = np.random.default_rng(1)
    # random angles, and rotations by pi (trace -1: where the trace formula alone breaks down)
    angles = np.concatenate([rng.uniform(-np.pi, np.pi, 200), np.full(20, np.pi)])
    axes = rng.normal(size=(angles.size, 3))
    axes[-3:] = np.eye(3)  # pi about each coordinate axis
    R = np.stack([axis_angle(a, t) for a, t in zip(axes, angles, strict=True)])
    q = view3d.quaternions(R)
    unit = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    expected = np.column_stack([unit * np.sin(angles / 2)[:, None], np.cos(angles / 2)])
    sign = np.sign(np.einsum("ij,ij->i", q, expected))
    np.testing.assert_allclose(q * sign[:, None], expected, atol=1e-14)


def test_quantised_poses_are_within_half_a_step() -> None:
    T = random_frames(50, 3)
    lo, hi = T[..., :3, 3].reshape(-1, 3).min(0), T[..., :3, 3].reshape(-1, 3).max(0)
    Q = view3d.quantise(T, lo, hi).astype(float)
    p = lo + (Q[..., :3] + 32767) / 65534 * (hi - lo)  # dequantised as view3d.js does
    q = Q[..., 3:] / 32767
    assert np.abs(p - T[..., :3, 3]).max() <= 0.5 * (hi - lo).max() / 65534 * (1 + 1e-9)
    ref = view3d.quaternions(T[..., :3, :3])
    sign = np.sign(np.einsum("...j,...j->...", q, ref))[..., None]
    assert np.abs(q - sign * ref).max() <= 0.5 / 32767 + 1e-12
    # consecutive frames' quaternions are on the same side (the viewer's slerp takes the short way)
    assert (np.einsum("kij,kij->ki", q[1:], q[:-1]) >= 0).all()


def test_packed_poses_decode_exactly_as_the_page_does() -> None:
    T = random_frames(60, 3, seed=4)
    lo, hi = T[..., :3, 3].reshape(-1, 3).min(0), T[..., :3, 3].reshape(-1, 3).max(0)
    Q = view3d.quantise(T, lo, hi)
    B = view3d.pack(Q).astype(np.int64)  # (2, n, 7, F)
    v = np.cumsum(B[0] | (B[1] << 8), axis=-1) % 65536  # view3d.js: running sum, mod 2^16
    decoded = np.where(v >= 32768, v - 65536, v).transpose(2, 0, 1)
    np.testing.assert_array_equal(decoded, Q)


def test_frame_indices_rate_budget_and_last_cycle() -> None:
    t = np.arange(12001) * 0.005  # 60 s at 5 ms
    idx = view3d.frame_indices(t, n_links=4)
    assert idx[0] == 0 and idx[-1] == t.size - 1
    assert np.diff(t[idx])[:-1].min() >= 1 / 30 - 1e-12  # at most 30 per second
    assert np.diff(idx)[:-1].max() == 7  # the smallest step that does it: 7 cycles = 35 ms
    capped = view3d.frame_indices(t, n_links=4, max_bytes=20_000)
    per_frame = view3d.POSE_BYTES * 4 * 2
    assert (capped.size - 1) * per_frame <= 20_000  # the appended last frame aside
    assert view3d.frame_indices(t[:1], 4).tolist() == [0]


def test_pool_flags_is_any_over_each_frames_cycles() -> None:
    rng = np.random.default_rng(2)
    flags = rng.random((1000, 3)) < 0.002
    idx = view3d.frame_indices(np.arange(1000) * 0.01, 3, max_fps=15)
    pooled = view3d.pool_flags(flags, idx)
    ends = [*idx[1:], 1000]
    brute = np.array([[flags[a:b, j].any() for j in range(3)]
                      for a, b in zip(idx, ends, strict=True)])
    np.testing.assert_array_equal(pooled.astype(bool), brute)


def test_payload_round_trip_and_no_script_breakout() -> None:
    F, n = 40, 2
    T = random_frames(F, n)
    t = np.arange(F) * 0.1
    sat = np.zeros((F, n), dtype=np.uint8)
    sat[5:9, 1] = 1
    names = ["a</script><script>alert(1)</script>", "b<!--"]
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    shapes = [[shp.Shape("sphere", (0.1,))], [shp.Shape("box", (0.1, 0.2, 0.3))],
              [shp.capsule_between((0, 0, 0), (0.5, 0, 0), 0.05, joint=1),
               shp.Shape("mesh", (2.0, 2.0, 2.0), vertices=square, faces=tri)]]
    spec = view3d.scene_data(t, T, T, shapes, sat, names, (0.0, 3.9, 0.01))
    page = view3d_html.scene_html(spec)
    body = re.search(r'class="mv3d-data">(.*?)</script>', page, re.S).group(1)
    assert "<" not in body  # so nothing in the data can close the script element
    back = json.loads(body)
    assert back["joints"] == names
    raw = gzip.decompress(base64.b64decode(back["payload"]))
    assert len(raw) == back["raw_bytes"]

    def section(key: str, dtype: type, where: list[int] | None = None) -> np.ndarray:
        o, c = where or back["bin"][key]
        return np.frombuffer(raw, dtype, c, o)

    np.testing.assert_array_equal(section("time", np.float64), t)
    np.testing.assert_array_equal(section("sat", np.uint8).reshape(F, n), sat)
    mesh = back["meshes"][back["shapes"][2][1]["m"]]
    np.testing.assert_array_equal(section("", np.float32, mesh["v"]).reshape(-1, 3), square)
    np.testing.assert_array_equal(section("", np.uint16, mesh["f"]).reshape(-1, 3), tri)
    # the slider is the cycle clock: its range and step
    assert 'min="0.0" max="3.9" step="0.01"' in page and 'type="range"' in page


def test_capsule_between_spans_the_two_points() -> None:
    a, b = np.array([0.1, -0.2, 0.3]), np.array([0.7, 0.4, -0.1])
    s = shp.capsule_between(a, b, 0.05)
    ends = [s.origin[:3, :3] @ [0, 0, z] + s.origin[:3, 3] for z in (-s.size[1] / 2,
                                                                        s.size[1] / 2)]
    np.testing.assert_allclose(ends, [a, b], atol=1e-15)
    np.testing.assert_allclose(s.origin[:3, :3].T @ s.origin[:3, :3], np.eye(3), atol=1e-15)


def test_figure_axes_are_the_axes_rectangle_and_limits() -> None:
    fig = Figure(figsize=(8, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.1, 0.2, 0.6, 0.5))
    ax.set_xlim(-1.0, 9.0)
    ax.set_xlabel("time t [s]")
    other = fig.add_axes((0.8, 0.2, 0.15, 0.5))
    other.set_xlabel("q [rad]")  # not a time axis: no marker
    got = json.loads(view3d_html.figure_axes(fig))
    np.testing.assert_allclose(got, [[0.1, 0.7, 0.2, 0.7, -1.0, 9.0]], atol=1e-12)


def sphere_mesh() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=5)  # 20480 faces, unit radius
    return mesh.vertices, mesh.faces


@pytest.mark.parametrize("quadric", [True, False])
@pytest.mark.parametrize("faces", [80, 2000])
def test_decimate_keeps_the_budget_and_the_surface(faces: int, quadric: bool,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    V, F = sphere_mesh()
    if not quadric:  # the fallback where quadric decimation misses the budget: a convex hull
        import fast_simplification  # of every k-th vertex

        monkeypatch.setattr(fast_simplification, "simplify", lambda V, F, **kw: (V, F[:0]))
    V2, F2 = shp.decimate(V, F, faces)
    assert 4 <= F2.shape[0] <= faces and F2.max() < V2.shape[0]
    # still the unit sphere's surface: a hull keeps some of its vertices, quadric decimation
    # moves vertices to where they fit the removed faces best (here slightly outside)
    r = np.linalg.norm(V2, axis=1)
    tol = 0.1 if quadric else 1e-9
    assert 0.9 <= r.min() and r.max() <= 1.0 + tol
    # and closed around its centre: the triangles enclose about the ball's volume 4/3 pi
    a, b, c = V2[F2[:, 0]], V2[F2[:, 1]], V2[F2[:, 2]]
    volume = abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6
    assert 0.7 < volume / (4 / 3 * np.pi) <= (1 + tol) ** 3


def two_link() -> Robot:
    joints = [Joint("j1", "revolute", "base", "l1", transform((0, 0, 0.4)), (0, 0, 1)),
              Joint("j2", "prismatic", "l1", "l2", transform((0.5, 0, 0)), (1, 0, 0))]
    links = [Link("l1", 1.0, (0.25, 0, 0), np.eye(3) * 0.01),
             Link("l2", 1.0, (0.1, 0, 0), np.eye(3) * 0.01)]
    return Robot(joints, links)


def test_fallback_capsules_join_the_joint_origins() -> None:
    robot = two_link()
    bodies = shp.robot_shapes(robot)
    assert len(bodies) == 3
    tip = shp.tip_point(robot)
    np.testing.assert_array_equal(tip, [0.2, 0, 0])  # twice the last link's com
    for body, end in ((0, (0, 0, 0.4)), (1, (0.5, 0, 0)), (2, tuple(tip))):
        caps = [s for s in bodies[body] if s.kind == "capsule"]
        assert len(caps) == 1
        s = caps[0]
        far = s.origin[:3, :3] @ [0, 0, s.size[1] / 2] + s.origin[:3, 3]
        near = s.origin[:3, :3] @ [0, 0, -s.size[1] / 2] + s.origin[:3, 3]
        np.testing.assert_allclose([near, far], [(0, 0, 0), end], atol=1e-15)
        assert s.joint == (None if body == 0 else body - 1)
    # the drive of joint 2 (prismatic: a rail) sits in link 1, along the joint axis, joint 2's
    rail = [s for s in bodies[1] if s.kind == "box"]
    assert len(rail) == 1 and rail[0].joint == 1
    np.testing.assert_allclose(rail[0].origin[:3, 2], [1, 0, 0], atol=1e-15)


def test_visuals_are_drawn_and_a_missing_mesh_falls_back(tmp_path) -> None:
    import trimesh
    robot = two_link()
    stl = tmp_path / "part.stl"
    trimesh.creation.box((0.1, 0.2, 0.3)).export(stl)
    box = Visual("box", (0.1, 0.1, 0.5), transform((0, 0, 0.25)), (1.0, 0.5, 0.0, 1.0))
    links = [Link("l1", 1.0, (0.25, 0, 0), np.eye(3) * 0.01,
                  (Visual("mesh", (2.0, 1.0, 1.0), mesh=str(stl)),)),
             Link("l2", 1.0, (0.1, 0, 0), np.eye(3) * 0.01,
                  (Visual("mesh", (1.0, 1.0, 1.0), mesh=str(tmp_path / "gone.stl")),))]
    robot = Robot(robot.joints, links, base_visuals=[box])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bodies = shp.robot_shapes(robot)
    assert len(caught) == 1 and "1 mesh file(s) not drawn" in str(caught[0].message)
    assert "gone.stl" in str(caught[0].message)
    assert [s.kind for s in bodies[0]] == ["box"] and bodies[0][0].color == 0xFF8000
    mesh = bodies[1][0]
    assert mesh.kind == "mesh" and mesh.joint == 0 and mesh.size == (2.0, 1.0, 1.0)
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), (0.1, 0.2, 0.3), rtol=1e-6)
    assert {s.kind for s in bodies[2]} == {"capsule"}  # the unreadable mesh: the fallback


def test_scene_budget_is_shared_in_proportion(tmp_path) -> None:
    import trimesh
    files = []
    for k, sub in enumerate((5, 4)):  # 20480 and 5120 faces
        files.append(tmp_path / f"s{k}.stl")
        trimesh.creation.icosphere(subdivisions=sub).export(files[-1])
    robot = two_link()
    links = [Link(lk.name, lk.mass, lk.com, lk.inertia, (Visual("mesh", (1, 1, 1), mesh=str(f)),))
             for lk, f in zip(robot.links, files, strict=True)]
    bodies = shp.robot_shapes(Robot(robot.joints, links), max_faces=2560)
    faces = [bodies[b][0].faces.shape[0] for b in (1, 2)]
    assert faces[0] <= 2048 and faces[1] <= 512 and sum(faces) <= 2560
    assert faces[0] > 0.9 * 2048 and faces[1] > 0.9 * 512  # quadric decimation meets it closely


def test_result_scene_of_a_run() -> None:
    """The scene of a real run: frames at the chosen cycles are the link frames of q and q_cmd,
    the slider spans the run on its cycle clock, the flags are the pooled saturation."""
    from mrnea.simulate import simulate

    robot = two_link().with_actuators(effort_limit=[0.5, 50.0])
    t = np.arange(300) * 0.01
    q_cmd = np.column_stack([np.sin(t), 0.1 * t])
    res = simulate(robot, q_cmd, 0.01)
    spec = view3d.result_scene(res)
    idx = view3d.frame_indices(res.t, 2)
    assert spec["frames"] == idx.size and spec["clock"] == {"t0": 0.0, "t1": 2.99, "dt": 0.01}
    raw = gzip.decompress(base64.b64decode(spec["payload"]))
    o, c = spec["bin"]["sat"]
    np.testing.assert_array_equal(np.frombuffer(raw, np.uint8, c, o).reshape(-1, 2),
                                  view3d.pool_flags(res.saturated, idx))
    assert res.saturated[:, 0].any()
    lo, hi = np.array(spec["box"][0]), np.array(spec["box"][1])
    for key, q in (("real", res.q), ("cmd", res.q_cmd)):
        o, c = spec["bin"][key]
        B = np.frombuffer(raw, np.uint8, c, o).astype(np.int64).reshape(2, 2, 7, -1)
        v = np.cumsum(B[0] | (B[1] << 8), axis=-1) % 65536
        Q = np.where(v >= 32768, v - 65536, v).transpose(2, 0, 1)
        origins = lo + (Q[..., :3] + 32767) / 65534 * (hi - lo)
        # link 2's origin: (0.5 cos q1, 0.5 sin q1, 0.4) + q2 along link 1's x
        q1, q2 = q[idx, 0], q[idx, 1]
        expected = np.column_stack([(0.5 + q2) * np.cos(q1), (0.5 + q2) * np.sin(q1),
                                    np.full(idx.size, 0.4)])
        assert np.abs(origins[:, 1] - expected).max() <= (hi - lo).max() / 65534
