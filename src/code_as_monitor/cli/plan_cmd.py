"""``cam plan``: print the subgoals and constraints the planner produces for an instruction.

With ``--backend kb`` (the default; a rule-based stand-in for a VLM, not a VLM) the whole plan is
printed by feeding "success" back after each subgoal. With ``--backend openai`` the first subgoal is
asked from any OpenAI-compatible server (``--max-subgoals`` asks for more, also assuming success).
``--backend replay --cassette FILE`` replays a recorded session; ``--record FILE`` records one.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from code_as_monitor.cli import validate as v
from code_as_monitor.cli.run_cmd import add_server_options, server_options

DESCRIPTION = "Plan an instruction: subgoals with their during/upon constraints (and optionally monitor code)."


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("plan", help="print the subgoals and constraints of an instruction",
                              description=DESCRIPTION)
    p.add_argument("instruction", help='e.g. "stack the blocks: red at the bottom, then green, then blue"')
    p.add_argument("--backend", choices=("kb", "openai", "replay"), default="kb",
                   help="kb: offline rule-based stand-in for a VLM (default); openai: any OpenAI-compatible "
                        "server; replay: a recorded cassette")
    p.add_argument("--base-url", default=None, help="server base URL ending in /v1 (openai; default api.openai.com)")
    p.add_argument("--model", default="gpt-4o", help="model name (openai)")
    p.add_argument("--api-key-env", default="OPENAI_API_KEY",
                   help="environment variable with the API key; 'none' for a local server without keys")
    add_server_options(p)
    p.add_argument("--objects", default=None,
                   help="comma-separated scene objects (default: inferred from the instruction)")
    p.add_argument("--image", action="append", default=[], metavar="[VIEW=]PATH",
                   help="an image of the scene for the model (repeatable); the view name defaults to the file stem")
    p.add_argument("--cassette", type=v.input_file, default=None, help="cassette to replay (--backend replay)")
    p.add_argument("--record", type=v.new_file, default=None, metavar="PATH",
                   help="record the session to this cassette (a new file)")
    p.add_argument("--max-subgoals", type=v.count(1, 10_000), default=None,
                   help="stop after this many subgoals (default: 12 for kb/replay, 1 for openai)")
    p.add_argument("--code", action="store_true", help="also write and print the monitor program of each subgoal")
    p.add_argument("--json", action="store_true", help="print one JSON document instead of text")
    p.set_defaults(func=run)


def _load_images(specs: list[str]) -> dict[str, Any]:
    """``[VIEW=]PATH`` specs -> view name -> RGB uint8 image."""
    from pathlib import Path

    import cv2

    from code_as_monitor.core.errors import ConfigError

    images: dict[str, Any] = {}
    for spec in specs:
        name, _, path = spec.rpartition("=")
        name = name or Path(path).stem
        if not path or not Path(path).is_file():  # cv2.imread would print its own warning first
            raise ConfigError(f"--image {spec}: cannot read an image from {path!r} (no such file)")
        bgr = cv2.imread(path, cv2.IMREAD_COLOR)
        if bgr is None:
            raise ConfigError(f"--image {spec}: cannot read an image from {path!r}")
        images[name] = bgr[:, :, ::-1].copy()
    return images


def _backend(args: argparse.Namespace) -> tuple[Any, str]:
    from code_as_monitor.core.errors import ConfigError
    from code_as_monitor.vlm.backend import (
        KBBackendConfig,
        OpenAIBackendConfig,
        ReplayBackendConfig,
        VLMBackendConfig,
        make_backend,
    )
    from code_as_monitor.vlm.kb import KB_DESCRIPTION

    if args.backend != "openai" and server_options(args):
        raise ConfigError(f"--timeout/--max-retries/--max-tokens/--no-images/--structured apply to the openai "
                          f"backend, not {args.backend!r}")
    inner: VLMBackendConfig
    if args.backend == "replay":
        if not args.cassette:
            raise ConfigError("--backend replay needs --cassette FILE")
        cfg: VLMBackendConfig = ReplayBackendConfig(cassette=str(args.cassette), mode="replay")
        return make_backend(cfg), f"replay of {args.cassette}"
    if args.backend == "openai":
        inner = OpenAIBackendConfig(model=args.model, base_url=args.base_url, api_key_env=args.api_key_env,
                                    **server_options(args))
        label = f"openai: {args.model} at {args.base_url or 'api.openai.com'}"
    else:
        inner = KBBackendConfig()
        label = KB_DESCRIPTION
    if args.record:
        return make_backend(ReplayBackendConfig(cassette=str(args.record), mode="record", inner=inner)), (
            f"{label}, recorded to {args.record}")
    return make_backend(inner), label


def _placeholder_elements(subgoal: Any) -> list[Any]:
    """Legend elements with placeholder points: the coder needs ids, kinds, names and owners only."""
    import numpy as np

    from code_as_monitor.core import Element
    from code_as_monitor.planning import legend_specs

    pts = {"point": [[0.0, 0.0, 0.0]], "line": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.1]],
           "surface": [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]}
    return [Element(i, s.name, s.kind, np.array(pts[s.kind.value]) + 0.01 * i, (s.obj, s.part))
            for i, s in enumerate(legend_specs(subgoal))]


def _format_subgoal(i: int, sg: Any) -> list[str]:
    if sg.done:
        return [f"{i}. {sg.text} (done)"]
    args = " ".join(f"{k}={v}" for k, v in sg.action.args.items()) if sg.action else ""
    lines = [f"{i}. {sg.text}  [{sg.action.skill if sg.action else '?'} {args}]".rstrip()]
    for c in sg.constraints:
        kind = "proactive" if c.proactive else "reactive"
        lines.append(f"   {c.phase.value:<6} {c.id} ({kind}): {c.text}")
        parts = ", ".join(f"{p.obj}{'/' + p.part if p.part else ''} ({p.kind.value})" for p in c.parts)
        if len(c.parts) > 6:
            parts = ", ".join(f"{p.obj}{'/' + p.part if p.part else ''} ({p.kind.value})" for p in c.parts[:3])
            parts += f", ... {len(c.parts) - 3} more"
        thr = ", ".join(f"{k}={v:g}" for k, v in c.thresholds.items())
        lines.append(f"          parts: {parts}" + (f" | thresholds: {thr}" if thr else ""))
    return lines


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.core.errors import ConfigError
    from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check
    from code_as_monitor.vlm.kb.planner import infer_objects
    from code_as_monitor.vlm.schemas import SUCCESS_FEEDBACK

    objects = [o.strip() for o in args.objects.split(",") if o.strip()] if args.objects else infer_objects(
        args.instruction)
    if not objects:
        raise ConfigError("no objects: pass --objects a,b,c")
    images = _load_images(args.image)
    backend, label = _backend(args)
    limit = args.max_subgoals if args.max_subgoals is not None else (1 if args.backend == "openai" else 12)
    if limit < 1:
        raise ConfigError(f"--max-subgoals must be >= 1, got {limit}")
    gen = ConstraintGenerator(backend)
    coder = MonitorCoder(backend, usage=gen.usage)
    plan: list[dict[str, Any]] = []
    shown = ", ".join(objects) if len(objects) <= 12 else (
        ", ".join(objects[:4]) + f", ... ({len(objects)} objects) ..., " + ", ".join(objects[-2:]))
    text: list[str] = [f"backend: {label}", f"instruction: {args.instruction}", f"objects: {shown}", ""]
    prev = None
    for i in range(1, limit + 1):
        sg = gen.next_subgoal(args.instruction, images, objects, prev, SUCCESS_FEEDBACK if prev else None)
        entry = sg.to_dict()
        text.extend(_format_subgoal(i, sg))
        if args.code and not sg.done:
            src = coder.write_program(sg, _placeholder_elements(sg), images,
                                      basic_check([c.id for c in sg.constraints]))
            entry["program"] = src
            text.extend("   | " + line for line in src.rstrip().splitlines())
        plan.append(entry)
        if sg.done:
            break
        prev = sg
    usage = gen.usage.episode()
    if args.json:
        print(json.dumps({"backend": label, "instruction": args.instruction, "objects": objects, "plan": plan,
                          "usage": gen.usage.to_dict()}, indent=2))
        return 0
    by = ", ".join(f"{k} {v}" for k, v in usage["calls_by_purpose"].items())
    est = " (estimated)" if usage["estimated"] else ""
    text += ["", f"usage: {usage['calls']} calls ({by}), {usage['prompt_tokens']} prompt + "
                 f"{usage['completion_tokens']} completion tokens{est}"]
    print("\n".join(text))
    return 0
