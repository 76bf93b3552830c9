"""The instruction table: instructions across the kb's seven task families with the plan each must produce, or
``REFUSE``. Shared by ``tests/vlm/test_vlm_instruction_table.py`` and ``benchmarks/kb_instructions.py``.

An expected plan is the whole action sequence the kb gives when every subgoal succeeds (and, for sweeping, the
accepted band and halting count). ``REFUSE`` rows are impossible or unsupported requests: a plan for one is a
wrong plan. A plannable row the kb refuses is counted as a refusal (allowed, reported), never as right.
"""

from __future__ import annotations

from itertools import pairwise
from typing import Any

from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import next_subgoal

REFUSE = "REFUSE"

SCENES: dict[str, list[str]] = {
    "stack": ["red_block", "green_block", "blue_block", "table"],
    "sweep": [f"block_{i:02d}" for i in range(40)] + ["zone", "table"],
    "rope": ["rope", "square", "table"],
    "pen": ["pen", "pen_holder", "table"],
    "book": ["book", "bookshelf", "table"],
    "tea": ["teapot", "teacup", "table"],
    "drawer": ["drawer_cabinet", "table"],
}

FIXED: dict[str, list[tuple[str, dict[str, Any]]]] = {
    "rope": [("close_shape", {"rope": "rope", "shape": "square", "coverage": 0.9})],
    "pen": [("grasp", {"obj": "pen", "part": "body"}), ("reorient", {"obj": "pen", "axis": "vertical"}),
            ("insert", {"obj": "pen", "target": "pen_holder"})],
    "book": [("grasp", {"obj": "book", "part": "cover"}), ("reorient", {"obj": "book", "axis": "vertical"}),
             ("stow", {"obj": "book", "target": "bookshelf"})],
    "tea": [("grasp", {"obj": "teapot", "part": "handle"}), ("transport", {"obj": "teapot", "target": "teacup"}),
            ("pour", {"obj": "teapot", "target": "teacup"}), ("drain", {"obj": "teapot", "target": "teacup"}),
            ("level", {"obj": "teapot"})],
    "drawer": [("grasp", {"obj": "drawer_cabinet", "part": "handle"}),
               ("pull", {"obj": "drawer_cabinet", "distance": 0.17, "min_open": 0.15})],
}


def drawer(opening: float) -> list[tuple[str, dict[str, Any]]]:
    """The drawer plan for an opening of ``opening`` metres: the pull goes 2 cm further."""
    return [("grasp", {"obj": "drawer_cabinet", "part": "handle"}),
            ("pull", {"obj": "drawer_cabinet", "distance": round(opening + 0.02, 4), "min_open": opening})]


def rope(coverage: float) -> list[tuple[str, dict[str, Any]]]:
    """The rope plan covering ``coverage`` of the opening (0.9: enclosed, the default)."""
    return [("close_shape", {"rope": "rope", "shape": "square", "coverage": coverage})]


def tower(*colours: str) -> list[tuple[str, dict[str, Any]]]:
    """The stacking plan for a tower (bottom first)."""
    names = [f"{c}_block" for c in colours]
    out: list[tuple[str, dict[str, Any]]] = []
    for below, block in pairwise(names):
        out += [("pick", {"obj": block}), ("place_on", {"obj": block, "target": below})]
    return out


def sweep(lower: int, upper: int, target: int) -> list[tuple[str, dict[str, Any]]]:
    """The sweeping plan with its band."""
    return [("push_into_region", {"region": "zone", "band": (lower, upper, target)})]


# (scene, instruction, expected)
TABLE: list[tuple[str, str, Any]] = [
    # --- stack-in-order: orders, paraphrases, synonyms -------------------------------------------------
    ("stack", "stack the blocks: red at the bottom, then green, then blue", tower("red", "green", "blue")),
    ("stack", "stack red on top of green on top of blue", tower("blue", "green", "red")),
    ("stack", "stack the blue block on the green block, then the red block on the blue block",
     tower("green", "blue", "red")),
    ("stack", "put the green block on the red block", tower("red", "green")),
    ("stack", "build a tower with blue at the bottom, green in the middle and red on top",
     tower("blue", "green", "red")),
    ("stack", "stack the red, green and blue blocks from top to bottom", tower("blue", "green", "red")),
    ("stack", "Stack the blocks so that green is at the bottom and blue is on top", tower("green", "red", "blue")),
    ("stack", "place the red cube on the blue one", tower("blue", "red")),
    ("stack", "pick up the green block and put it on the red block, then put the blue block on the green block",
     tower("red", "green", "blue")),
    ("stack", "make a tower: blue, red, green from the bottom up", tower("blue", "red", "green")),
    ("stack", "stack the red block under the blue block", tower("red", "blue")),
    ("stack", "put blue on the table, then green on blue, then red on green", tower("blue", "green", "red")),
    ("stack", "stack the three blocks with red on top of blue and green at the bottom", tower("green", "blue", "red")),
    ("stack", "stack the blocks in any order", tower("red", "green", "blue")),
    ("stack", "put the red block on top of the green block and the green block on top of the blue block",
     tower("blue", "green", "red")),
    ("stack", "Please pile the blocks up with the red one as the base, the blue one in the middle and the green "
              "one at the top", tower("red", "blue", "green")),
    ("stack", "stack all three blocks into a single tower, red at the base and blue at the top",
     tower("red", "green", "blue")),
    ("stack", "build a tower of red, green and blue blocks, bottom to top", tower("red", "green", "blue")),
    ("stack", "build one tower of blue, green and red from the top down", tower("red", "green", "blue")),
    ("stack", "stack red and green, red at the bottom", tower("red", "green")),
    ("stack", "stack red, green and blue, blue at the bottom", tower("blue", "green", "red")),
    ("stack", "put the blue block on top of the green block, which sits on the red block",
     tower("red", "green", "blue")),
    ("stack", "put the green block on the red block, which stands on the table", tower("red", "green")),
    # --- stack-in-order: impossible or under-specified -----------------------------------------------------
    ("stack", "stack the blocks into two towers", REFUSE),
    ("stack", "stack red, green and blue, green at the bottom", REFUSE),
    ("stack", "stack the yellow block on the red block", REFUSE),
    ("stack", "stack red on green and green on red", REFUSE),
    ("stack", "stack the blocks with blue on top", REFUSE),
    ("stack", "put the red block on the red block", REFUSE),
    ("stack", "stack the blocks from top to bottom", REFUSE),
    ("stack", "don't stack the blue block", REFUSE),
    ("stack", "stack four blocks", REFUSE),
    ("stack", "put the red block next to the green block", REFUSE),
    ("stack", "stack red on top of green which is on top of blue", tower("blue", "green", "red")),
    ("stack", "put red where blue is", REFUSE),
    ("stack", "stack the blocks with blue first", REFUSE),
    ("stack", "stack the red block on the green block first", REFUSE),
    # --- sweep-half: counts ------------------------------------------------------------------------------
    ("sweep", "sweep half of the blocks into the zone", sweep(16, 24, 18)),
    ("sweep", "push 10 blocks into the zone", sweep(9, 11, 10)),
    ("sweep", "push ten of the blocks into the target area", sweep(9, 11, 10)),
    ("sweep", "sweep all the blocks into the zone", sweep(36, 40, 40)),
    ("sweep", "Please push about twenty blocks into the marked region", sweep(16, 24, 18)),
    ("sweep", "push exactly 12 blocks into the zone", sweep(12, 12, 12)),
    ("sweep", "push at least 30 blocks into the zone", sweep(30, 40, 30)),
    ("sweep", "sweep a quarter of the blocks into the zone", sweep(6, 14, 8)),
    ("sweep", "push between 6 and 10 of the 40 blocks into the zone", sweep(6, 10, 7)),
    ("sweep", "sweep 25% of the blocks into the zone", sweep(6, 14, 8)),
    ("sweep", "sweep the blocks into the zone", sweep(36, 40, 40)),
    ("sweep", "push 50 blocks into the zone", REFUSE),
    ("sweep", "push no more than 10 blocks into the zone", REFUSE),
    ("sweep", "sweep half of the blocks out of the zone", REFUSE),
    ("sweep", "push some blocks into the zone", REFUSE),
    ("sweep", "push half of the blocks in the pile into the zone", sweep(16, 24, 18)),
    ("sweep", "sweep half of the pile into the yellow zone", sweep(16, 24, 18)),
    ("sweep", "push half the blocks from the pile into the zone", sweep(16, 24, 18)),
    ("sweep", "sweep half of the pile out of the zone", REFUSE),
    ("sweep", "push half of the 30 blocks into the zone", REFUSE),
    ("sweep", "sweep half of the red blocks into the zone", REFUSE),
    ("sweep", "push 2 dozen blocks into the zone", sweep(22, 26, 23)),
    ("sweep", "push 10.5 blocks into the zone", REFUSE),
    ("sweep", "push 10 12 blocks into the zone", REFUSE),
    ("sweep", "push the block into the zone", REFUSE),
    # --- rope-close-square ------------------------------------------------------------------------------
    ("rope", "use the rope to close the opening of the square", FIXED["rope"]),
    ("rope", "close the gap in the square with the rope", FIXED["rope"]),
    ("rope", "drag the rope across the open side of the square", FIXED["rope"]),
    ("rope", "seal the opening using the cord", FIXED["rope"]),
    ("rope", "put the rope around the square", REFUSE),
    ("rope", "close the opening of the square with the pen", REFUSE),
    ("rope", "use the rope to make a circle", REFUSE),
    ("rope", "close half of the opening with the rope", rope(0.5)),
    ("rope", "use the cord to close at least 80% of the opening of the square", rope(0.8)),
    ("rope", "cover the whole opening with the rope", FIXED["rope"]),
    ("rope", "close the opening of the square completely using the rope", FIXED["rope"]),
    ("rope", "pick up the rope and lay it across the opening", FIXED["rope"]),
    ("rope", "put the rope into the square", REFUSE),
    ("rope", "stack the rope on the square", REFUSE),
    ("rope", "close at most half of the opening with the rope", REFUSE),
    ("rope", "close half of half of the opening with the rope", REFUSE),
    ("rope", "close the opening with the rope and the cord", REFUSE),
    # --- slot-pen ---------------------------------------------------------------------------------------
    ("pen", "put the pen into the pen holder", FIXED["pen"]),
    ("pen", "drop the pen into the pencil cup", FIXED["pen"]),
    ("pen", "insert the pen tip first into the holder", FIXED["pen"]),
    ("pen", "pick up the pen and put it in the pen cup", FIXED["pen"]),
    ("pen", "slot the pen into the holder", FIXED["pen"]),
    ("pen", "put the pen into the holder with the tip down", FIXED["pen"]),
    ("pen", "insert the pen into the holder with its point first", FIXED["pen"]),
    ("pen", "put the pen into the holder with the cap down", REFUSE),
    ("pen", "put the pencil in the cup", REFUSE),
    ("pen", "put the pen on the holder", REFUSE),
    ("pen", "put the pen into the bookshelf", REFUSE),
    # --- stow-book --------------------------------------------------------------------------------------
    ("book", "shelve the book", FIXED["book"]),
    ("pen", "turn the pen upright", REFUSE),
    ("book", "put the book upright into the bookcase", FIXED["book"]),
    ("book", "stow the book on the shelf", FIXED["book"]),
    ("book", "stand the book up in the bookshelf", FIXED["book"]),
    ("book", "return the book to the shelf", FIXED["book"]),
    ("book", "put the book flat on the shelf", REFUSE),
    ("book", "put the book into the drawer", REFUSE),
    ("book", "put the book on top of the shelf", REFUSE),
    # --- pour-tea ---------------------------------------------------------------------------------------
    ("tea", "pour the tea from the teapot into the teacup", FIXED["tea"]),
    ("tea", "fill the teacup from the teapot", FIXED["tea"]),
    ("tea", "pour the teapot into the cup", FIXED["tea"]),
    ("tea", "pour a cup of tea", FIXED["tea"]),
    ("tea", "serve the tea into the mug", FIXED["tea"]),
    ("tea", "tilt the teapot to pour the tea into the cup", FIXED["tea"]),
    ("tea", "pour the tea into the cup by tilting the teapot", FIXED["tea"]),
    ("tea", "tilt the teacup to pour into the teapot", REFUSE),
    ("tea", "pour half the tea into the cup", REFUSE),
    ("tea", "pour the tea onto the table", REFUSE),
    ("tea", "pour the tea into the pen holder", REFUSE),
    ("tea", "pour the tea into the cup and then pour it back", REFUSE),
    ("tea", "pour the tea into both cups", REFUSE),
    ("pen", "put the pen in the holder then in the cup", REFUSE),
    ("pen", "put both pens into the holder", REFUSE),
    ("drawer", "open both drawers", REFUSE),
    ("sweep", "push both blocks into the zone", REFUSE),
    ("sweep", "push half the blocks into half the zone", REFUSE),
    # --- open-drawer ------------------------------------------------------------------------------------
    ("drawer", "open the drawer by pulling its handle", FIXED["drawer"]),
    ("drawer", "slide the drawer out", FIXED["drawer"]),
    ("drawer", "pull out the drawer", FIXED["drawer"]),
    ("drawer", "grasp the handle of the drawer and pull it open", FIXED["drawer"]),
    ("drawer", "open the cabinet drawer", FIXED["drawer"]),
    ("drawer", "close the drawer", REFUSE),
    ("drawer", "open the teapot", REFUSE),
    ("drawer", "open the drawer halfway", drawer(0.125)),
    ("drawer", "pull the drawer out by 4 inches", drawer(0.1016)),
    ("drawer", "open the drawer at least 8 cm by its handle", drawer(0.08)),
    ("drawer", "open the drawer 10 cm", drawer(0.10)),
    ("drawer", "open the drawer fully", REFUSE),
    ("drawer", "pull the drawer out 20 cm", REFUSE),
    ("drawer", "open the drawer up to 10 cm", REFUSE),
    ("drawer", "open the drawer -10 cm", REFUSE),
    # --- plain requests the kb does not read (yet): each refusal is counted, never a wrong plan ----------
    ("stack", "stack them: red first, green second and blue last", tower("red", "green", "blue")),
    ("sweep", "push the blocks into the zone until half of them are inside", sweep(16, 24, 18)),
    ("sweep", "sweep the blocks so that half of them end up in the zone", sweep(16, 24, 18)),
    ("rope", "use the string to block the open end of the square", FIXED["rope"]),
    # --- nothing the kb knows ---------------------------------------------------------------------------
    ("book", "stack the pen on the book", REFUSE),
    ("stack", "juggle three oranges", REFUSE),
]


def plan_of(instruction: str, objects: list[str], limit: int = 12) -> list[tuple[str, dict[str, Any]]]:
    """The kb's whole plan (feeding success after each subgoal); raises InstructionError on a refusal."""
    previous, feedback, out = None, None, []
    for _ in range(limit):
        answer = next_subgoal({"instruction": instruction, "objects": objects, "previous_subgoal": previous,
                               "feedback": feedback})
        if answer["done"]:
            return out
        skill, args = answer["action"]["skill"], dict(answer["action"]["args"])
        if skill == "push_into_region":
            thr = next(c["thresholds"] for c in answer["constraints"] if c["id"].startswith("reached_"))
            args["band"] = (int(thr["lower"]), int(thr["upper"]), int(thr["target"]))
        if skill == "close_shape":
            args["coverage"] = answer["constraints"][0]["thresholds"]["min_fraction"]
        if skill == "pull":  # the pull's checks follow the opening asked for
            thr = next((c["thresholds"] for c in answer["constraints"] if c["id"].startswith("pulled_")), {})
            args["min_open"] = thr.get("min_open")
        out.append((skill, args))
        previous, feedback = answer, "success"
    raise AssertionError(f"no end after {limit} subgoals: {instruction!r}")


def judge(instruction: str, objects: list[str], expected: Any) -> tuple[str, str]:
    """``("right" | "refused" | "wrong", detail)`` for one row."""
    from code_as_monitor.core.errors import InstructionError

    try:
        got = plan_of(instruction, objects)
    except InstructionError as exc:
        if expected == REFUSE:
            return "right", str(exc)
        return "refused", str(exc)
    if expected == REFUSE:
        return "wrong", f"planned {got} for an instruction that must be refused"
    return ("right", "") if got == expected else ("wrong", f"planned {got}, expected {expected}")


def counts(rows: list[tuple[str, str, Any]] | None = None) -> tuple[dict[str, int], list[tuple[str, str, str]]]:
    """Right / refused / wrong over ``rows`` (default the table), and the rows that were not right."""
    total = {"right": 0, "refused": 0, "wrong": 0}
    misses = []
    for scene, instruction, expected in rows or TABLE:
        verdict, detail = judge(instruction, SCENES[scene], expected)
        total[verdict] += 1
        if verdict != "right":
            misses.append((verdict, instruction, detail))
    return total, misses


__all__ = ["FIXED", "REFUSE", "SCENES", "TABLE", "KBBackend", "counts", "judge", "plan_of", "sweep", "tower"]
