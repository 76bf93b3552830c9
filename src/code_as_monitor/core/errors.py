"""The project's exception types. Every library error derives from :class:`CamError`.

The CLI catches ``CamError`` (and ``ValueError`` subclasses below), prints one line and exits 2.
"""

from __future__ import annotations


class CamError(Exception):
    """Base class of every error this library raises on purpose."""


class ConfigError(CamError, ValueError):
    """A configuration value is invalid (the message names the field and the value)."""


class UnknownChoiceError(ConfigError, KeyError):
    """A registry was asked for a name it does not hold."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class MissingExtraError(CamError, ImportError):
    """An optional dependency is missing; the message says which extra to install."""


class GeometryError(CamError, ValueError):
    """Bad geometric input: wrong shapes, a non-invertible K, a non-rigid transform, ..."""


class ShapeMismatchError(GeometryError):
    """Two arrays that must share a shape do not (for example a mask and a depth image)."""


class NoValidDepthError(GeometryError):
    """A mask has no pixel with a valid depth reading, so nothing can be lifted to 3-D."""


class ElementError(CamError, ValueError):
    """An element cannot be built (unknown kind, wrong point count, degenerate points)."""


class PerceptionError(CamError):
    """Segmentation or tracking failed in a way the caller must handle."""


class VLMError(CamError):
    """A VLM backend failed: unreachable server, exhausted retries, or an answer that never validates."""


class VLMConfigError(VLMError, ConfigError):
    """A VLM backend is misconfigured (missing API key, bad base URL)."""


class VLMOutputError(VLMError, ValueError):
    """The model's answer could not be parsed or validated after the allowed re-asks."""


class VLMRequestError(VLMError):
    """The server refused a request for a reason a retry cannot change (HTTP 4xx); the message names the fix."""


class VLMImageError(VLMRequestError):
    """The model does not take images (use ``--no-images`` or serve a vision model)."""


class VLMContextError(VLMRequestError):
    """The prompt and the answer do not fit: the server's context is too small, or the answer was cut off at
    ``max_tokens``; the message says which number to raise."""


class VLMTimeoutError(VLMError):
    """The server gave no complete answer within the request timeout (the request was closed)."""


class InstructionError(VLMError, ValueError):
    """An instruction the kb (or the task goal it maps to) cannot understand or honour; the message names the
    words it did not understand, or what it cannot do, and the task families it knows."""


class ReplayMissError(VLMError, KeyError):
    """A replay cassette has no entry for a request; the message names the request hash."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class ProgramError(CamError, ValueError):
    """A monitor program is rejected by static validation or path-coverage testing."""


class SandboxError(CamError):
    """The sandbox worker could not be started or talked to."""


class ObservationError(CamError, ValueError):
    """An observation handed to the monitor is unusable (a view missing, time going backwards)."""


class RecordingError(CamError, ValueError):
    """A recording (a ROS 2 bag) cannot be read or written: missing, truncated or corrupt, a topic
    missing, an unknown encoding, sizes that do not match."""


class SimError(CamError):
    """The simulator was asked for something it cannot do."""


class RunError(CamError):
    """A run directory or results file is unusable (exists already, corrupt, ...)."""
