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
        TaskRef(
            "beat_the_buzz",
            "level2",
            "beat the buzz",
            ("wand", "buzz wire", "start rest", "end rest"),
            f"{_PKG}.unseen.beat_the_buzz:BeatTheBuzz",
        ),
        TaskRef(
            "basketball_in_hoop",
            "level2",
            "put the ball in the hoop",
            ("ball", "hoop"),
            f"{_PKG}.unseen.basketball_in_hoop:BasketballInHoop",
        ),
        TaskRef(
            "water_plants",
            "level2",
            "water plant",
            ("watering can", "plant"),
            f"{_PKG}.unseen.water_plants:WaterPlants",
        ),
        TaskRef(
            "scoop_with_spatula",
            "level2",
            "scoop up the cube and lift it with the spatula",
            ("spatula", "cube"),
            f"{_PKG}.unseen.scoop_with_spatula:ScoopWithSpatula",
        ),
        TaskRef(
            "close_fridge",
            "level1",
            "close fridge",
            ("fridge", "fridge top door", "fridge bottom door"),
            f"{_PKG}.unseen.close_fridge:CloseFridge",
        ),
        TaskRef(
            "close_laptop_lid",
            "level1",
            "close laptop lid",
            ("laptop", "laptop lid"),
            f"{_PKG}.unseen.close_laptop_lid:CloseLaptopLid",
        ),
        TaskRef(
            "toilet_seat_down",
            "level1",
            "toilet seat down",
            ("toilet", "toilet seat"),
            f"{_PKG}.unseen.toilet_seat_down:ToiletSeatDown",
        ),
        TaskRef(
            "lamp_off",
            "level1",
            "turn off the light",
            ("lamp", "lamp button"),
            f"{_PKG}.unseen.lamp_off:LampOff",
        ),
        TaskRef(
            "lamp_on",
            "level1",
            "turn on the light",
            ("lamp", "lamp button"),
            f"{_PKG}.unseen.lamp_on:LampOn",
        ),
        TaskRef(
            "open_grill",
            "level1",
            "open the grill",
            ("grill", "grill lid", "grill lid handle"),
            f"{_PKG}.unseen.open_grill:OpenGrill",
        ),
        TaskRef(
            "put_toilet_roll_on_stand",
            "level1",
            "put toilet roll on stand",
            ("toilet roll", "toilet roll stand"),
            f"{_PKG}.unseen.put_toilet_roll_on_stand:PutToiletRollOnStand",
        ),
        TaskRef(
            "phone_on_base",
            "level1",
            "put the phone on the base",
            ("phone", "phone base"),
            f"{_PKG}.unseen.phone_on_base:PhoneOnBase",
        ),
        TaskRef(
            "put_rubbish_in_bin",
            "level1",
            "put rubbish in bin",
            ("rubbish", "tomato 1", "tomato 2", "bin"),
            f"{_PKG}.unseen.put_rubbish_in_bin:PutRubbishInBin",
        ),
        TaskRef(
            "put_knife_on_chopping_board",
            "level1",
            "put the knife on the chopping board",
            ("knife", "knife block", "chopping board"),
            f"{_PKG}.unseen.put_knife_on_chopping_board:PutKnifeOnChoppingBoard",
        ),
        TaskRef(
            "put_books_on_bookshelf",
            "level1",
            "put 1 books on bookshelf",
            ("book 1", "book 2", "book 3", "bookshelf", "top shelf"),
            f"{_PKG}.unseen.put_books_on_bookshelf:PutBooksOnBookshelf",
        ),
        TaskRef(
            "put_umbrella_in_umbrella_stand",
            "level1",
            "put umbrella in umbrella stand",
            ("umbrella", "umbrella stand"),
            f"{_PKG}.unseen.put_umbrella_in_umbrella_stand:PutUmbrellaInUmbrellaStand",
        ),
        TaskRef(
            "turn_oven_on",
            "level2",
            "turn on the oven",
            ("oven", "left oven knob", "right oven knob"),
            f"{_PKG}.unseen.turn_oven_on:TurnOvenOn",
        ),
        TaskRef(
            "take_usb_out_of_computer",
            "level2",
            "take usb out of computer",
            ("computer", "usb stick"),
            f"{_PKG}.unseen.take_usb_out_of_computer:TakeUsbOutOfComputer",
        ),
        TaskRef(
            "unplug_charger",
            "level2",
            "unplug charger",
            ("charger", "wall socket", "wall"),
            f"{_PKG}.unseen.unplug_charger:UnplugCharger",
        ),
        TaskRef(
            "take_lid_off_saucepan",
            "level2",
            "take lid off the saucepan",
            ("saucepan", "saucepan lid"),
            f"{_PKG}.unseen.take_lid_off_saucepan:TakeLidOffSaucepan",
        ),
        TaskRef(
            "take_plate_off_colored_dish_rack",
            "level2",
            "take plate off the black colored rack",
            ("plate", "dish rack", "black rack", "red rack", "purple rack"),
            f"{_PKG}.unseen.take_plate_off_colored_dish_rack:TakePlateOffColoredDishRack",
        ),
        TaskRef(
            "straighten_rope",
            "level2",
            "straighten rope",
            ("rope", "rope head", "rope tail", "head target", "tail target"),
            f"{_PKG}.unseen.straighten_rope:StraightenRope",
        ),
    )
}


def get_task(name: str) -> TaskRef:
    try:
        return TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task '{name}'; available: {', '.join(sorted(TASKS))}") from None
