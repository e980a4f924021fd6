"""The exceptions articula raises (re-exported by the package)."""


class Error(Exception):
    """Every error articula raises on purpose derives from this class."""


class ModelError(Error, ValueError):
    """A model cannot be loaded: a missing or unreadable file, malformed URDF, an unsupported
    joint type, inertias no rigid body has, a bad load option. The message names the file,
    link or joint."""


class DynamicsError(Error, ValueError):
    """A dynamics call cannot run or gave no finite answer: a wrong shape, a NaN or infinite
    input (named by joint), a non-unit quaternion, a singular body, a Data of another model."""


class DivergenceError(DynamicsError):
    """A simulation's energy guard tripped: the energy grew beyond the allowed bound (the step
    is too large for the model's stiffness, or the motion diverged)."""


class SceneError(Error, ValueError):
    """A scene file or spec is invalid (the message names the file and field), or a scene step
    failed."""
