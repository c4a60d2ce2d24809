"""KinematicChain.from_urdf: the built-in head written as URDF, the iCub head of icub-models
(checked against yourdfpy's own forward kinematics), joint limits and the errors."""

from __future__ import annotations

import sys
from pathlib import Path

import icub_models
import numpy as np
import pytest
import yourdfpy

from perception import (
    Joint,
    KinematicChain,
    MissingExtraError,
    PerceptionError,
    RobotFileError,
    default_head,
)
from perception.head.chain import TIP_FROM_OPENCV

ICUB = str(icub_models.get_model_file("iCubGazeboV2_7"))
HALF_BASELINE = 0.093 / 2.0
LIMIT = 1.0
AXES = {"x": "1 0 0", "y": "0 1 0", "z": "0 0 1", "-x": "-1 0 0", "-y": "0 -1 0", "-z": "0 0 -1"}


def write_urdf(path: Path, joints: list[tuple[str, str, str, str, str, str, str]]) -> Path:
    """A URDF with one link per name in the joints ``(name, type, parent, child, xyz, rpy, axis)``."""
    links = sorted({j[2] for j in joints} | {j[3] for j in joints})
    lines = ['<?xml version="1.0"?>', '<robot name="head">']
    lines += [f'  <link name="{name}"/>' for name in links]
    for name, kind, parent, child, xyz, rpy, axis in joints:
        lines.append(f'  <joint name="{name}" type="{kind}">')
        lines.append(f'    <parent link="{parent}"/>\n    <child link="{child}"/>')
        lines.append(f'    <origin xyz="{xyz}" rpy="{rpy}"/>')
        if kind != "fixed":
            lines.append(f'    <axis xyz="{axis}"/>')
        if kind in ("revolute", "prismatic"):
            lines.append(f'    <limit lower="{-LIMIT}" upper="{LIMIT}" effort="1" velocity="1"/>')
        lines.append("  </joint>")
    lines.append("</robot>")
    path.write_text("\n".join(lines))
    return path


def builtin_head_urdf(path: Path, split: bool = False, flip: tuple[str, ...] = ()) -> Path:
    """The built-in head (default_head(0.093)), offsets typed from its docstring's geometry.

    ``split`` puts a fixed joint into the head-tilt offset and a fixed camera link below each eye;
    ``flip`` names joints whose URDF axis points the other way (their angle changes sign).
    """
    spec = [  # name, parent, child, offset, axis
        ("neck_pitch", "base", "neck_1", "0 0 0", "y"),
        ("neck_roll", "neck_1", "neck_2", "0 0 0.02", "x"),
        ("neck_yaw", "neck_2", "neck_3", "0 0 0.03", "z"),
        ("head_tilt", "neck_3", "head", "0 0 0.12", "y"),
        ("eye_tilt", "head", "eyes", "0.06 0 0.08", "y"),
        ("left_eye_pan", "eyes", "left_eye", f"0.02 {HALF_BASELINE} 0", "z"),
        ("right_eye_pan", "eyes", "right_eye", f"0.02 {-HALF_BASELINE} 0", "z"),
    ]
    joints = []
    for name, parent, child, xyz, axis in spec:
        axis = AXES[("-" if name in flip else "") + axis]
        if split and name == "head_tilt":
            joints.append(("neck_top", "fixed", parent, "neck_4", "0 0 0.05", "0 0 0", ""))
            parent, xyz = "neck_4", "0 0 0.07"
        joints.append((name, "revolute", parent, child, xyz, "0 0 0", axis))
    if split:
        joints.append(("left_mount", "fixed", "left_eye", "left_camera", "0 0 0", "0 0 0", ""))
    return write_urdf(path, joints)


def random_angles(chain: KinematicChain, rng: np.random.Generator, n: int) -> np.ndarray:
    lims = chain.limits
    return rng.uniform(lims[:, 0], lims[:, 1], size=(n, len(lims)))


@pytest.mark.parametrize(
    ("split", "flip"),
    [(False, ()), (True, ()), (False, ("neck_pitch", "eye_tilt")), (True, ("neck_roll", "left_eye_pan"))],
)
def test_builtin_head_from_urdf_matches_default_head(tmp_path: Path, split: bool, flip: tuple) -> None:
    urdf = builtin_head_urdf(tmp_path / "head.urdf", split=split, flip=flip)
    chain = KinematicChain.from_urdf(urdf, "base", "left_camera" if split else "left_eye")
    builtin = default_head(0.093)
    assert chain.names == builtin.names[:6]
    np.testing.assert_array_equal(chain.limits, [[-LIMIT, LIMIT]] * 6)
    sign = np.array([-1.0 if name in flip else 1.0 for name in chain.names])
    rng = np.random.default_rng(15)
    for q in random_angles(chain, rng, 25):
        np.testing.assert_allclose(chain.ego_from_camera(q), builtin.ego_from_camera(sign * q), atol=1e-14)
    # the right eye: a chain of its own down to the right eye link
    right = KinematicChain.from_urdf(urdf, "base", "right_eye")
    assert right.names == builtin.names[:5] + ("right_eye_pan",)
    for q in rng.uniform(-LIMIT, LIMIT, size=(10, 7)):
        q_right = np.append(q[:5], q[6])
        sign_right = np.append(sign[:5], -1.0 if "right_eye_pan" in flip else 1.0)
        np.testing.assert_allclose(right.ego_from_camera(sign_right * q_right),
                                   builtin.ego_from_right_camera(q), atol=1e-14)


def test_zero_angles_by_hand(tmp_path: Path) -> None:
    urdf = builtin_head_urdf(tmp_path / "h.urdf", split=True)
    chain = KinematicChain.from_urdf(urdf, "base", "left_camera")
    M = chain.ego_from_camera(np.zeros(6))
    # left camera centre: neck 0.02 + 0.03 + 0.12 + 0.08 up, 0.06 + 0.02 forward, half baseline left
    np.testing.assert_allclose(M[:3, 3], [0.08, HALF_BASELINE, 0.25], atol=1e-15)
    # OpenCV camera looking along ego x: x right = -y, y down = -z, z forward = +x
    np.testing.assert_allclose(M[:3, :3], [[0, 0, 1], [-1, 0, 0], [0, -1, 0]], atol=1e-15)
    # the neck yaw turns the line of sight about ego z
    q = np.zeros(6)
    q[2] = 0.75
    np.testing.assert_allclose(chain.ego_from_camera(q)[:3, 2], [np.cos(0.75), np.sin(0.75), 0], atol=1e-15)


def yourdfpy_pose(urdf: yourdfpy.URDF, chain: KinematicChain, q: np.ndarray, base: str, camera: str
                  ) -> np.ndarray:
    """``base_from_camera`` by yourdfpy's own forward kinematics (the independent reference)."""
    urdf.update_cfg(dict(zip(chain.names, q, strict=True)))
    return urdf.get_transform(frame_to=camera, frame_from=base)


@pytest.mark.parametrize(
    ("base", "camera", "link_from_camera"),
    [("root_link", "head_imu_0", np.eye(4)), ("chest", "head", TIP_FROM_OPENCV), ("chest", "neck_1", None)],
)
def test_icub_head_matches_yourdfpy(base: str, camera: str, link_from_camera: np.ndarray | None) -> None:
    chain = (KinematicChain.from_urdf(ICUB, base, camera) if link_from_camera is None
             else KinematicChain.from_urdf(ICUB, base, camera, link_from_camera))
    camera_pose = TIP_FROM_OPENCV if link_from_camera is None else link_from_camera
    reference = yourdfpy.URDF.load(ICUB, load_meshes=False)
    expected_names = {"head_imu_0": ("torso_pitch", "torso_roll", "torso_yaw", "neck_pitch", "neck_roll",
                                     "neck_yaw"),
                      "head": ("neck_pitch", "neck_roll", "neck_yaw"), "neck_1": ("neck_pitch",)}
    assert chain.names == expected_names[camera]
    assert np.all(np.isfinite(chain.limits)) and np.all(chain.limits[:, 0] < chain.limits[:, 1])
    rng = np.random.default_rng(2)
    for q in random_angles(chain, rng, 20):
        expected = yourdfpy_pose(reference, chain, q, base, camera) @ camera_pose
        np.testing.assert_allclose(chain.ego_from_camera(q), expected, atol=1e-12)


def test_icub_point_jacobian_finite_differences() -> None:
    chain = KinematicChain.from_urdf(ICUB, "root_link", "head_imu_0")
    q = 0.5 * chain.limits.mean(axis=1) + 0.1
    x = np.array([0.1, -0.2, 1.5])
    h = 1e-6
    num = np.zeros((3, chain.n_joints))
    for k in range(chain.n_joints):
        dq = np.zeros(chain.n_joints)
        dq[k] = h
        plus = (chain.ego_from_camera(q + dq) @ np.append(x, 1.0))[:3]
        minus = (chain.ego_from_camera(q - dq) @ np.append(x, 1.0))[:3]
        num[:, k] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(chain.point_jacobian(q, x), num, atol=1e-8)


def test_oblique_axes_and_rotated_origins_match_yourdfpy(tmp_path: Path) -> None:
    joints = [
        ("j0", "revolute", "base", "a", "0.1 0 0.2", "0.3 -0.2 0.5", "0.3 -0.5 0.8"),
        ("f0", "fixed", "a", "b", "0 0.05 0", "0 1.5707963267948966 0", ""),
        ("j1", "continuous", "b", "c", "0.02 0 0.1", "0 0 0", "-0.6 0 0.8"),
        ("j2", "revolute", "c", "d", "0 0 0.07", "-0.4 0 1.1", "0 0 -1"),
        ("j3", "revolute", "d", "e", "0.01 0.02 0.03", "0 0 0", "0.999 0.001 0"),
        ("f1", "fixed", "e", "cam", "0.03 0 0", "1.0 0.2 -0.3", ""),
    ]
    urdf = write_urdf(tmp_path / "oblique.urdf", joints)
    chain = KinematicChain.from_urdf(urdf, "base", "cam", np.eye(4))
    assert chain.names == ("j0", "j1", "j2", "j3")
    assert np.isinf(chain.limits[1]).all()  # continuous: no limits
    reference = yourdfpy.URDF.load(str(urdf), load_meshes=False)
    rng = np.random.default_rng(8)
    for q in rng.uniform(-LIMIT, LIMIT, size=(20, 4)):
        expected = yourdfpy_pose(reference, chain, q, "base", "cam")
        np.testing.assert_allclose(chain.ego_from_camera(q), expected, atol=1e-12)


def test_joint_limits_enforced() -> None:
    chain = KinematicChain.from_urdf(ICUB, "chest", "head")
    lower, upper = chain.limits.T
    chain.ego_from_camera(lower)  # the limits themselves are allowed
    chain.ego_from_camera(upper)
    q = 0.5 * (lower + upper)
    q[1] = upper[1] + 0.01
    with pytest.raises(PerceptionError, match=rf"'neck_roll' \(index 1\) = {float(q[1])!r}"):
        chain.ego_from_camera(q)
    with pytest.raises(PerceptionError, match=r"'neck_pitch' \(index 0\) = -0\.7 "):
        chain.ego_from_camera({"neck_pitch": -0.7, "neck_roll": 0.0, "neck_yaw": 0.0})
    with pytest.raises(PerceptionError, match=r"angle of joint 'neck_yaw'"):
        chain.point_jacobian(np.array([0.0, 0.0, -0.9]), [0.0, 0.0, 1.0])
    # degrees are caught before the limits, with the hint
    with pytest.raises(PerceptionError, match=r"angle of joint 'neck_yaw' \(index 2\) =.*degrees"):
        chain.ego_from_camera([0.0, 0.0, 45.0])
    # the joints themselves
    joint = Joint("pan", "z", np.eye(4), lower=-0.5, upper=0.25)
    np.testing.assert_allclose(joint.transform(0.25)[:2, 0], [np.cos(0.25), np.sin(0.25)], atol=1e-15)
    with pytest.raises(PerceptionError, match=r"'pan' = 0\.3 lies outside .*\[-0\.5, 0\.25\]"):
        joint.transform(0.3)
    with pytest.raises(PerceptionError, match=r"lower limit 1\.0 exceeds upper limit 0\.0"):
        Joint("pan", "z", np.eye(4), lower=1.0, upper=0.0)
    with pytest.raises(PerceptionError, match="upper limit of joint 'pan'"):
        Joint("pan", "z", np.eye(4), upper=float("nan"))
    one_sided = KinematicChain((Joint("pan", "z", np.eye(4), lower=0.0),), np.eye(4), np.eye(4))
    np.testing.assert_array_equal(one_sided.limits, [[0.0, np.inf]])
    with pytest.raises(PerceptionError, match=r"'pan' \(index 0\) = -0\.1"):
        one_sided.ego_from_camera([-0.1])


def test_missing_and_unconnected_links(tmp_path: Path) -> None:
    urdf = builtin_head_urdf(tmp_path / "head.urdf")
    with pytest.raises(RobotFileError, match="base_link 'torso' is not a link .*'neck_1'"):
        KinematicChain.from_urdf(urdf, "torso", "left_eye")
    with pytest.raises(RobotFileError, match="camera_link 'left_camera' is not a link"):
        KinematicChain.from_urdf(urdf, "base", "left_camera")
    with pytest.raises(RobotFileError, match="no path from base_link 'head' down to camera_link 'neck_1'"):
        KinematicChain.from_urdf(urdf, "head", "neck_1")
    with pytest.raises(RobotFileError, match=r"'right_eye'.*ancestors are \['eyes', 'head'"):
        KinematicChain.from_urdf(urdf, "right_eye", "left_eye")
    with pytest.raises(RobotFileError,
                       match="no revolute joint between base_link 'head' and camera_link 'head'"):
        KinematicChain.from_urdf(urdf, "head", "head")
    with pytest.raises(RobotFileError, match="does not exist"):
        KinematicChain.from_urdf(tmp_path / "missing.urdf", "base", "left_eye")
    broken = tmp_path / "broken.urdf"
    broken.write_text("this is not XML")
    with pytest.raises(RobotFileError, match="cannot be read"):
        KinematicChain.from_urdf(broken, "a", "a")
    with pytest.raises(RobotFileError, match="base_link must be a non-empty"):
        KinematicChain.from_urdf(urdf, "", "left_eye")
    with pytest.raises(PerceptionError, match=r"link_from_camera must have shape \(4, 4\)"):
        KinematicChain.from_urdf(urdf, "base", "left_eye", np.eye(3))


def test_unsupported_joints(tmp_path: Path) -> None:
    joints = [
        ("pan", "revolute", "base", "a", "0 0 0", "0 0 0", "0 0 1"),
        ("slide", "prismatic", "a", "b", "0 0 0.1", "0 0 0", "1 0 0"),
        ("tilt", "revolute", "b", "cam", "0 0 0", "0 0 0", "0 1 0"),
    ]
    urdf = write_urdf(tmp_path / "slide.urdf", joints)
    with pytest.raises(RobotFileError, match=r"joint 'slide' \(index 1 on the path.*'prismatic'"):
        KinematicChain.from_urdf(urdf, "base", "cam")
    assert KinematicChain.from_urdf(urdf, "base", "a").names == ("pan",)  # above the slide: fine
    mimic = write_urdf(tmp_path / "mimic.urdf", [joints[0], ("tilt", "revolute", "a", "cam", "0 0 0", "0 0 0",
                                                              "0 1 0")])
    mimic.write_text(mimic.read_text().replace('<axis xyz="0 1 0"/>',
                                               '<axis xyz="0 1 0"/><mimic joint="pan" multiplier="2"/>'))
    with pytest.raises(RobotFileError, match=r"joint 'tilt' \(index 1 on the path\) mimics joint 'pan'"):
        KinematicChain.from_urdf(mimic, "base", "cam")
    zero_axis = write_urdf(tmp_path / "zero.urdf",
                           [("pan", "revolute", "base", "cam", "0 0 0", "0 0 0", "0 0 0")])
    with pytest.raises(RobotFileError, match="'pan'.*axis must be a finite non-zero"):
        KinematicChain.from_urdf(zero_axis, "base", "cam")


def test_missing_yourdfpy_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    urdf = builtin_head_urdf(tmp_path / "head.urdf")
    monkeypatch.setitem(sys.modules, "yourdfpy", None)  # import yourdfpy now raises ImportError
    with pytest.raises(MissingExtraError, match=r"pip install gaussian-spheres\[urdf\]") as info:
        KinematicChain.from_urdf(urdf, "base", "left_eye")
    assert isinstance(info.value, ImportError) and isinstance(info.value, PerceptionError)


def test_gaze_angles_keep_the_urdf_limits() -> None:
    from worldgraph.active import gaze_angles
    from worldgraph.errors import WorldGraphError

    chain = KinematicChain.from_urdf(ICUB, "chest", "head")
    lower, upper = chain.limits.T
    q_true = np.array([-0.3, 0.2, 0.5])
    target = (chain.ego_from_camera(q_true) @ [0.0, 0.0, 2.0, 1.0])[:3]  # 2 m along the optical axis
    q, err, within = gaze_angles(chain, target)
    assert err < 1e-4 and within is True
    assert np.all((q >= lower) & (q <= upper))
    behind = (chain.ego_from_camera(np.zeros(3)) @ [0.0, 0.0, -2.0, 1.0])[:3]  # out of reach
    q, err, within = gaze_angles(chain, behind)
    assert err > 1.0 and within is True
    assert np.all((q >= lower) & (q <= upper))
    q, _, _ = gaze_angles(chain, target, joint_limits={"neck_yaw": (-0.1, 0.1)})
    assert -0.1 <= q[2] <= 0.1
    with pytest.raises(WorldGraphError, match=r"neck_yaw.*\[5\.0, 6\.0\] does not meet"):
        gaze_angles(chain, target, joint_limits={"neck_yaw": (5.0, 6.0)})
