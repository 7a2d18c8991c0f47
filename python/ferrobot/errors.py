"""Exceptions raised by ferrobot.

Every error ferrobot raises derives from :class:`FerrobotError`. Errors about
bad arguments also derive from the matching built-in (``ValueError``,
``LookupError``), so existing ``except ValueError`` code keeps working.
"""

from __future__ import annotations

__all__ = [
    "FerrobotError",
    "ModelError",
    "UrdfError",
    "MeshError",
    "SrdfError",
    "UnknownNameError",
    "ShapeError",
    "NonFiniteError",
    "InvalidArgumentError",
    "InternalError",
    "FileFormatError",
    "DuplicateNameError",
    "SimulationDiverged",
    "ServiceError",
    "RequestRejectedError",
    "SrdfWarning",
]


class FerrobotError(Exception):
    """Base class of every ferrobot exception."""


class ModelError(FerrobotError):
    """A robot description could not be loaded."""


class UrdfError(ModelError):
    """Malformed URDF, unsupported or unknown joint type, kinematic loop, several roots, ...

    The message starts with ``FILE:LINE:`` where the line is known.
    """


class MeshError(UrdfError):
    """A mesh named by the URDF is missing or unreadable (the message lists the paths tried); also an object
    mesh file (``World.add_mesh_file``, ``load_mesh``) that is missing, unreadable, empty, huge, degenerate or
    non-manifold (the message names the file)."""


class SrdfError(ModelError):
    """Malformed SRDF, or an SRDF naming links, joints or groups the URDF lacks."""


class UnknownNameError(FerrobotError, LookupError):
    """A link, joint, group or named state that the model does not have."""


class ShapeError(FerrobotError, ValueError):
    """An array argument has the wrong number of dimensions or the wrong length."""


class NonFiniteError(FerrobotError, ValueError):
    """A NaN or infinite value where a finite number is required."""


class InvalidArgumentError(FerrobotError, ValueError, TypeError):
    """Any other invalid argument (wrong type, out-of-range option, ...)."""


class FileFormatError(FerrobotError, ValueError):
    """A scene YAML, sphere YAML or spherized URDF that cannot be read (the message names file and element)."""


class DuplicateNameError(FerrobotError, ValueError):
    """A world or attached object name that is taken already."""


class InternalError(FerrobotError, RuntimeError):
    """A bug inside ferrobot (a Rust panic caught at the boundary); please report it.

    Every entry point of the extension (functions, methods, constructors, getters) runs behind a
    panic guard, so pyo3's ``PanicException`` (a ``BaseException`` that ``except Exception`` misses)
    never reaches Python.
    """


class SimulationDiverged(FerrobotError, RuntimeError):
    """A simulation blew up (non-finite or runaway body states); the message names the body, step and time.

    Also raised when the physics engine fails inside a step. The ``World`` stays usable: ``reset()``
    returns it to its initial state.
    """


class ServiceError(FerrobotError):
    """The grasp service could not answer: every server address failed (unreachable, timed out, 5xx)."""


class RequestRejectedError(ServiceError, ValueError):
    """The grasp service rejected the request (4xx); the message carries the server's reason."""


class SrdfWarning(UserWarning):
    """SRDF entries skipped by a lenient load (names the URDF lacks, a ``group_state`` without ``group``).

    MoveIt's srdfdom skips such entries with a warning; so does ``RobotModel.from_urdf`` unless
    ``strict=True``. ``RobotModel.srdf_warnings`` lists what was skipped.
    """
