"""vlm layer: backends (``openai``, ``kb``, ``replay``), prompts, output schemas and token accounting.

- :mod:`.messages`: :class:`Message` with text and RGB image parts.
- :mod:`.backend`: the :class:`VLMBackend` protocol, :class:`VLMResponse`, the registered configs
  (:class:`VLMBackendConfig` ``openai`` | ``kb`` | ``replay``) and :func:`make_backend`.
- :mod:`.kb`: the offline knowledge base, a rule-based stand-in for a VLM (not a VLM).
- :mod:`.schemas`: the pydantic schema of the constraint generator's JSON answer.
- :mod:`.usage`: calls and tokens per subgoal and per episode.
- ``prompts/``: versioned prompt templates (:mod:`.templates` renders them).
"""

from code_as_monitor.vlm.backend import (
    KBBackendConfig,
    OpenAIBackendConfig,
    ReplayBackendConfig,
    VLMBackend,
    VLMBackendConfig,
    VLMResponse,
    make_backend,
)
from code_as_monitor.vlm.messages import ImagePart, Message, TextPart
from code_as_monitor.vlm.schemas import SUCCESS_FEEDBACK, GeneratorOutput, parse_generator_output
from code_as_monitor.vlm.usage import UsageMeter, UsageRecord

__all__ = [
    "SUCCESS_FEEDBACK",
    "GeneratorOutput",
    "ImagePart",
    "KBBackendConfig",
    "Message",
    "OpenAIBackendConfig",
    "ReplayBackendConfig",
    "TextPart",
    "UsageMeter",
    "UsageRecord",
    "VLMBackend",
    "VLMBackendConfig",
    "VLMResponse",
    "make_backend",
    "parse_generator_output",
]
