"""The SAPIEN tasks, listed without importing sapien.

Each entry keeps the task's static facts (so `TaskInfo` is available cheaply) and where its class
lives; tests/test_sapien_tasks.py checks that these facts match the task classes.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from xicm.core.types import TaskInfo


@dataclass(frozen=True)
class TaskRef:
    """A task registered by name; `load_class()` imports the real class (and sapien)."""

    name: str
    split: str
    instruction: str
    object_names: tuple[str, ...]
    target: str  # "module:Class"

    def info(self) -> TaskInfo:
        return TaskInfo(self.name, self.split, self.instruction, self.object_names)

    def load_class(self):
        module, cls = self.target.split(":")
        return getattr(importlib.import_module(module), cls)

    def __call__(self, *args, **kwargs):
        return self.load_class()(*args, **kwargs)


_PKG = "xicm.plugins.simulators.sapien.tasks"

TASKS: dict[str, TaskRef] = {
    ref.name: ref
    for ref in (
        TaskRef(
            "open_drawer",
            "seen",
            "open the top drawer",
            ("top drawer handle", "middle drawer handle", "bottom drawer handle"),
            f"{_PKG}.seen.open_drawer:OpenDrawer",
        ),
        TaskRef(
            "push_buttons",
            "seen",
            "push the red button",
            ("red button", "green button", "blue button"),
            f"{_PKG}.seen.push_buttons:PushButtons",
        ),
        TaskRef(
            "close_jar",
            "seen",
            "close the red jar",
            ("red jar", "green jar", "jar lid"),
            f"{_PKG}.seen.close_jar:CloseJar",
        ),
        TaskRef(
            "stack_blocks",
            "seen",
            "stack 2 red blocks",
            (
                "red block 1", "red block 2", "red block 3", "red block 4",
                "green block 1", "green block 2", "green block 3", "green block 4",
                "stacking area",
            ),  # fmt: skip
            f"{_PKG}.seen.stack_blocks:StackBlocks",
        ),
        TaskRef(
            "put_item_in_drawer",
            "seen",
            "put the item in the top drawer",
            ("item", "top drawer handle", "middle drawer handle", "bottom drawer handle"),
            f"{_PKG}.seen.put_item_in_drawer:PutItemInDrawer",
        ),
        TaskRef(
            "turn_tap",
            "seen",
            "turn left tap",
            ("left tap", "right tap", "faucet"),
            f"{_PKG}.seen.turn_tap:TurnTap",
        ),
        TaskRef(
            "slide_block_to_color_target",
            "seen",
            "slide the block to green target",
            ("block", "green target", "blue target", "pink target", "yellow target"),
            f"{_PKG}.seen.slide_block_to_color_target:SlideBlockToColorTarget",
        ),
        TaskRef(
            "meat_off_grill",
            "seen",
            "take the chicken off the grill",
            ("chicken", "steak", "grill"),
            f"{_PKG}.seen.meat_off_grill:MeatOffGrill",
        ),
        TaskRef(
            "put_money_in_safe",
            "seen",
            "put the money away in the safe on the bottom shelf",
            ("money", "safe", "bottom shelf", "middle shelf", "top shelf"),
            f"{_PKG}.seen.put_money_in_safe:PutMoneyInSafe",
        ),
        TaskRef(
            "insert_onto_square_peg",
            "seen",
            "put the ring on the red spoke",
            ("square ring", "red spoke", "green spoke", "blue spoke"),
            f"{_PKG}.seen.insert_onto_square_peg:InsertOntoSquarePeg",
        ),
        TaskRef(
            "put_groceries_in_cupboard",
            "seen",
            "put the soup in the cupboard",
            ("soup", "crackers", "mustard", "sugar", "cupboard"),
            f"{_PKG}.seen.put_groceries_in_cupboard:PutGroceriesInCupboard",
        ),
        TaskRef(
            "place_wine_at_rack_location",
            "seen",
            "stack the wine bottle to the left of the rack",
            ("wine bottle", "left slot", "middle slot", "right slot"),
            f"{_PKG}.seen.place_wine_at_rack_location:PlaceWineAtRackLocation",
        ),
        TaskRef(
            "reach_and_drag",
            "seen",
            "use the stick to drag the cube onto the red target",
            ("stick", "cube", "red target", "green target", "blue target", "yellow target"),
            f"{_PKG}.seen.reach_and_drag:ReachAndDrag",
        ),
        TaskRef(
            "stack_cups",
            "seen",
            "stack the other cups on top of the red cup",
            ("red cup", "green cup", "blue cup"),
            f"{_PKG}.seen.stack_cups:StackCups",
        ),
        TaskRef(
            "place_shape_in_shape_sorter",
            "seen",
            "put the cube in the shape sorter",
            ("shape sorter", "cube", "cylinder", "cross", "cuboid"),
            f"{_PKG}.seen.place_shape_in_shape_sorter:PlaceShapeInShapeSorter",
        ),
        TaskRef(
            "light_bulb_in",
            "seen",
            "screw in the red light bulb",
            ("red light bulb", "green light bulb", "lamp"),
            f"{_PKG}.seen.light_bulb_in:LightBulbIn",
        ),
        TaskRef(
            "sweep_to_dustpan_of_size",
            "seen",
            "sweep dirt to the tall dustpan",
            ("broom", "dirt", "tall dustpan", "short dustpan"),
            f"{_PKG}.seen.sweep_to_dustpan_of_size:SweepToDustpanOfSize",
        ),
        TaskRef(
            "place_cups",
            "seen",
            "place 1 cup on the cup holder",
            ("red cup", "green cup", "blue cup", "cup holder"),
            f"{_PKG}.seen.place_cups:PlaceCups",
        ),
        TaskRef(
            "close_microwave",
            "level1",
            "close microwave",
            ("microwave", "microwave door", "microwave door handle"),
            f"{_PKG}.unseen.close_microwave:CloseMicrowave",
        ),
    )
}


def get_task(name: str) -> TaskRef:
    try:
        return TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task '{name}'; available: {', '.join(sorted(TASKS))}") from None
