"""SAPIEN tasks with a named target (a drawer, tap, colour, slot, item, knob): the task's own
scripted demonstrator, aimed at another target, gets there, and that is not a success."""

import pytest
from task_demos import go, run_demo_aimed

# task, seed, the attribute the demonstrator aims by, the wrong value (from the task and the
# real value), and where the demonstrator got instead (from the task, the wrong and the real value)
WRONG_TARGETS = [
    ("close_jar", 0, "target_jar",
     lambda t, real: next(j for j in t.jars if j is not real),
     lambda t, wrong, real: t.lid_on(wrong) and not t.grasped()),
    ("stack_cups", 1, "variation",
     lambda t, real: (real + 1) % 3,
     lambda t, wrong, real: all(t.inside(i, wrong) for i in range(3) if i != wrong)),  # a neat stack, on the wrong cup
    ("put_item_in_drawer", 2, "variation",
     lambda t, real: (real + 1) % 3,
     lambda t, wrong, real: t.in_drawer(wrong) and not t.in_drawer(real)),
    ("meat_off_grill", 0, "variation",
     lambda t, real: 1 - real,
     lambda t, wrong, real: t.off_grill(wrong) and not t.off_grill(real) and not t.grasped()),
    ("put_money_in_safe", 0, "variation",
     lambda t, real: (real + 1) % 3,
     lambda t, wrong, real: t.shelf_of_money() == wrong and not t.grasped()),
    ("insert_onto_square_peg", 0, "target",
     lambda t, real: (real + 1) % 3,
     lambda t, wrong, real: t.spoke_of_ring() == wrong),
    ("put_groceries_in_cupboard", 0, "variation",
     lambda t, real: (real + 1) % len(t.items),
     lambda t, wrong, real: t.in_cupboard(wrong) and not t.in_cupboard(real) and not t.grasped()),
    ("place_wine_at_rack_location", 0, "variation",
     lambda t, real: (real + 1) % 3,
     lambda t, wrong, real: t.slot_of_bottle() == wrong and not t.grasped()),
    ("place_shape_in_shape_sorter", 2, "variation",
     lambda t, real: (real + 1) % 4,
     lambda t, wrong, real: t.in_sorter(wrong)),
    ("light_bulb_in", 0, "variation",
     lambda t, real: 1 - real,
     lambda t, wrong, real: t.in_lamp(wrong)),
    ("put_rubbish_in_bin", 0, "rubbish",  # a tomato in the bin
     lambda t, real: t.tomatoes[0],
     lambda t, wrong, real: t.in_bin(wrong) and not t.in_bin(real)),
    ("put_books_on_bookshelf", 0, "books",  # book 2 shelved instead of book 1
     lambda t, real: [real[1], real[0], real[2]],
     lambda t, wrong, real: t.on_top_shelf(1) and not t.on_top_shelf(0)),
    ("turn_tap", 3, "variation",
     lambda t, real: 1 - real,
     lambda t, wrong, real: t.turned()[wrong] > 1.6 and t.turned()[real] < 0.2),
    ("reach_and_drag", 3, "variation",
     lambda t, real: (real + 1) % 4,
     lambda t, wrong, real: t.cube_on(wrong)),
    ("slide_block_to_color_target", 4, "variation",
     lambda t, real: (real + 2) % 4,
     lambda t, wrong, real: t.on_target(wrong) and not t.on_target(real)),
    ("sweep_to_dustpan_of_size", 1, "variation",
     lambda t, real: 1 - real,
     lambda t, wrong, real: t.dirt_in(wrong)),
]  # fmt: skip


@pytest.mark.parametrize(("task", "seed", "aim", "wrong_of", "reached"), WRONG_TARGETS, ids=[c[0] for c in WRONG_TARGETS])
def test_the_demonstrator_aimed_at_another_target_is_not_a_success(physics_sim, task, seed, aim, wrong_of, reached):
    physics_sim.reset_state(task, seed, 0)
    real = getattr(physics_sim.task, aim)
    wrong = wrong_of(physics_sim.task, real)
    run_demo_aimed(physics_sim, aim, wrong)
    assert reached(physics_sim.task, wrong, real)
    assert not physics_sim.is_success()


def test_turning_the_right_oven_knob_does_not_turn_the_oven_on(physics_sim):
    physics_sim.reset_state("turn_oven_on", 0, 0)
    for action in physics_sim.task.demonstration(index=1):  # the demonstrator, pointed at the right knob
        go(physics_sim, action)
    turned = physics_sim.task.turned()
    assert turned[1] > 1.6 and turned[0] < 0.1
    assert not physics_sim.is_success()
