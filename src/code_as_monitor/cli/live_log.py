"""The live episode log printed by ``cam demo`` and ``cam run`` (rich, CLI layer only)."""

from __future__ import annotations

from typing import Any

from rich.console import Console
from rich.table import Table


class LiveLog:
    """Prints agent events as they happen: subgoals, constraints, legend, violations, outcome."""

    def __init__(self, console: Console | None = None, verbose: bool = False) -> None:
        self.c = console or Console(highlight=False)
        self.verbose = verbose

    def __call__(self, ev: dict[str, Any]) -> None:
        k = ev.get("kind")
        t = ev.get("t")
        ts = f"[dim]{t:6.2f}s[/dim] " if isinstance(t, (int, float)) else "        "
        c = self.c
        if k == "episode_start":
            c.rule(f"[bold]{ev['instruction']}")
        elif k == "subgoal":
            sg = ev["subgoal"]
            c.print(f"{ts}[bold cyan]subgoal {ev['index']}[/]: {sg['text']}  "
                    f"[dim]({(sg.get('action') or {}).get('skill', '')})[/]")
            for con in sg["constraints"]:
                tag = "proactive" if con.get("proactive") else "reactive"
                c.print(f"          [magenta]{con['phase']:>6}[/] [dim]{tag:9}[/] {con['id']}: {con['text']}")
        elif k == "elements":
            legend = ", ".join(f"{e['id']}={e['name']} ({e['kind']})" for e in ev["legend"])
            c.print(f"          [dim]elements: {legend}  painted in {ev['seconds'] * 1000:.0f} ms[/]")
        elif k == "element_missing":
            c.print(f"{ts}[yellow]no view sees {ev['spec']['obj']}/{ev['spec']['part'] or '*'}[/]")
        elif k == "program":
            c.print(f"          [dim]monitor program accepted after {ev['attempts']} attempt(s)[/]")
        elif k == "program_rejected":
            c.print(f"{ts}[yellow]monitor program rejected: {ev['error']}[/]")
        elif k == "alarm":
            kind = "PROACTIVE" if ev.get("proactive") else "REACTIVE"
            c.print(f"{ts}[bold red]{kind} violation[/] {ev['constraint_id']}: {ev['reason']}")
        elif k == "early_halt":
            c.print(f"{ts}[green]all upon constraints hold: policy halted early[/]")
        elif k == "subgoal_end":
            colour = "green" if ev["outcome"] == "success" else "red"
            c.print(f"{ts}[{colour}]{ev['outcome']}[/]  [dim]{ev['reason'][:160]}[/]")
            if ev["outcome"] != "success":
                c.print("          [yellow]re-planning with this failure as feedback[/]")
        elif k == "task_complete_claimed":
            c.print(f"{ts}[dim]the planner calls the task complete: judging the last subgoal again at rest[/]")
        elif k == "rest_check":
            if ev.get("judged") is False:
                mm = 1000 * ev["moved"]
                word = f"[green]at rest, moved {mm:.0f} mm since it was judged: the completion stands[/]"
            else:
                word = "[green]still holds at rest[/]" if ev["ok"] else "[red]no longer holds at rest[/]"
            c.print(f"{ts}{word}")
        elif k == "program_fault" and self.verbose:
            c.print(f"{ts}[yellow]program fault[/] {ev['constraint_id']}: {ev['reason']}")
        elif k == "verdicts_unknown" and self.verbose and ev["constraints"]:
            c.print(f"{ts}[dim]stale elements {ev['stale_elements']}: no verdict for {ev['constraints']}[/]")
        elif k == "episode_end":
            c.print(f"{ts}[bold]episode ended[/]: {ev['stop_reason']} ({ev['replans']} re-plans)")
        elif k == "outcome":
            self.outcome(ev)
        elif k == "run_stopped":
            c.print(f"[bold red]{ev['outcome'].upper()}[/]  {ev['reason']}")

    def outcome(self, ev: dict[str, Any]) -> None:
        if "success" not in ev:  # a bag replay (cam monitor): a recording neither succeeds nor fails
            frames = ev.get("frames") or {}
            self.c.print(f"[bold]{str(ev.get('outcome', '')).upper()}[/]  {ev.get('reason')}; "
                         f"{ev.get('alarms', 0)} alarm(s), {frames.get('judged', 0)} frames judged")
            return
        vlm = ev.get("vlm") or {}
        tab = Table(show_header=False, box=None, padding=(0, 2))
        verdict = "[bold green]SUCCESS[/]" if ev["success"] else "[bold red]FAILURE[/]"
        tab.add_row("outcome", f"{verdict}  {ev['reason']}")
        tab.add_row("sim time", f"{ev['sim_time_s']:.1f} s")
        est = " (estimated from text length)" if vlm.get("estimated") else ""
        tab.add_row("VLM calls", f"{vlm.get('calls', 0)} ({vlm.get('calls_per_subgoal', 0)} per subgoal)")
        tokens = f"{vlm.get('prompt_tokens', 0)} prompt + {vlm.get('completion_tokens', 0)} completion{est}"
        tab.add_row("tokens", tokens)
        self.c.print(tab)
