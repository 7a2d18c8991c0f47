"""ferrobot: robot manipulation on an ordinary CPU.

Conventions (everywhere in the public API):

* SI units (metres, radians, seconds, kilograms).
* Quaternions are ``(w, x, y, z)``; poses are 4x4 homogeneous matrices or
  7-vectors ``[x, y, z, qw, qx, qy, qz]``.
* Arrays are float64 numpy arrays, batch dimension first; joint vectors are in
  ``RobotModel.dof_names`` order.
"""

from __future__ import annotations

# _builds first: importing it loads the best per-level build of a wheel as ferrobot._core (issue 22)
from . import _builds, _core, calibration, camera, errors, grasp, pipeline, robots, scenarios, transforms
from ._core import (
    ArbiterConflict,
    Camera,
    Clearance,
    CollisionChecker,
    CollisionDistance,
    CollisionWorld,
    CommandDelay,
    Contact,
    ControlStepInfo,
    DepthNoiseParams,
    DetectOptions,
    DriveGains,
    FingerGeometry,
    FrictionFit,
    Gripper,  # the one gripper description (issue 17)
    GripperDetection,
    GuidancePlan,
    IkOptions,
    IkResult,
    Inertial,
    JointInfo,
    JointLimits,
    JointPID,
    JointTrajectory,
    Lighting,
    LinearPredictor,
    LinkInertial,
    LinkMassFit,
    LoadedMesh,
    PayloadFit,
    Planner,
    PlanOptions,
    PlanResult,
    PlanTimes,
    PotentialFieldController,
    ReactiveController,
    RenderFrame,
    ResolvedRateController,
    Robot,
    RobotModel,
    SelfCollisionAnalysis,
    SphereDistances,
    SphereFit,
    SphereModel,
    StreamGuard,
    StreamGuardStep,
    TrackingReport,
    UrdfCheckReport,
    UrdfFinding,
    World,
    WorldSyncStats,
    __version__,
    load_mesh,
    look_at,
    opencv_to_opengl,
    opengl_to_opencv,
)

simd_level = _builds.simd_level  # the instruction-set level of the loaded build (issue 22)
simd_info = _builds.simd_info

__all__ = [
    "simd_info",  # which per-level build was loaded (issue 22)
    "simd_level",
    "CommandDelay",
    "LinearPredictor",
    "StreamGuard",
    "calibration",
    "camera",
    "scenarios",
    "Camera",
    "CollisionChecker",
    "CollisionWorld",
    "IkResult",
    "JointTrajectory",
    "Planner",
    "PlanResult",
    "JointPID",
    "PotentialFieldController",
    "ReactiveController",
    "ResolvedRateController",
    "Robot",
    "RobotModel",
    "SphereModel",
    "World",
    "load_mesh",
    "depth_to_points",
    "look_at",
    "opencv_to_opengl",
    "opengl_to_opencv",
    "errors",
    "grasp",
    "pipeline",
    "transforms",
    "robots",
    "__version__",
    "DetectOptions",
    "IkOptions",
    "PlanOptions",
    "Gripper",
    # typed results (issue 16)
    "ControlStepInfo",
    "DriveGains",
    "RenderFrame",
    "CollisionDistance",
    "Contact",
    "SelfCollisionAnalysis",
    "SphereFit",
    "SphereDistances",
    "Clearance",
    "GuidancePlan",
    "LinkInertial",
    "Inertial",
    "JointInfo",
    "Lighting",
    "JointLimits",
    "PlanTimes",
    "FingerGeometry",
    "GripperDetection",
    "TrackingReport",
    "WorldSyncStats",
    "PayloadFit",
    "LinkMassFit",
    "FrictionFit",
    "ArbiterConflict",
    "StreamGuardStep",
    "DepthNoiseParams",
    "UrdfFinding",
    "UrdfCheckReport",
    "LoadedMesh",
]


def depth_to_points(depth, fx: float, fy: float, cx: float, cy: float):
    """Deprecated: use :func:`ferrobot.camera.backproject` (pixels as (row, column)).

    Back-projects a depth image (H, W) in metres; returns ``(points (N, 3), flat pixel indices (N,))``.
    Same policy as the new function: 0 and +inf are missing; NaN, -inf and negative depths raise.
    """
    import warnings

    warnings.warn(
        "ferrobot.depth_to_points is deprecated; use ferrobot.camera.backproject(depth, "
        "ferrobot.camera.Intrinsics(...))"
        " instead",
        DeprecationWarning,
        stacklevel=2,
    )
    return _core.depth_to_points(depth, fx, fy, cx, cy)
