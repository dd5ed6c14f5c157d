"""lamp_on (unseen, level 1).

Task description:
    The desk lamp of lamp_off (round black base with a red push button at its front, a stem at
    the back, an arm reaching further back to a green shade with a bulb), but the light is off
    (the bulb is dull). The robot presses the button down with its closed gripper, which
    switches the light on.

Randomisations:
    - lamp centre x in [0.15, 0.35] m, y in [-0.20, 0.20] m, yaw in [-90, 90] degrees (as lamp_off);
    - the direction of the lamp's arm: in [-30, 30] degrees from straight back (simulator.scenes:
      rlbench: straight back, as lamp_off).

Success conditions:
    The button has been pressed in by more than 3 mm, which switched the light on (every press
    toggles the light; a press is counted again only after the button came back up), and the
    light is on. Under simulator.scenes: rlbench, as lamp_off: the button in by more than 3 mm now,
    no toggle.
"""

from __future__ import annotations

from .lamp_off import LampTask


class LampOn(LampTask):
    name = "lamp_on"
    max_control_steps = 46  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    instruction = "turn on the light"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "turn on the light",
        "press the button to turn on the lamp",
        "press the light switch",
        "turn the lamp on",
        "close the gripper and press on the button until the light turns on",
    )
    start_lit = False
