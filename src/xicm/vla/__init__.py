"""xicm for vision-language-action models: every task as a Gymnasium environment.

    import gymnasium, xicm.vla   # importing xicm.vla registers "xicm/<CamelCaseTask>-v0"
    env = gymnasium.make("xicm/OpenDrawer-v0", obs_mode="rgb", control_mode="ee_delta",
                         render_mode="rgb_array", cameras=["front", "wrist"], image_size=224)

or without the import: gymnasium.make("xicm.vla:xicm/OpenDrawer-v0", ...). Needs
`pip install 'xicm[vla]'` (gymnasium).
"""

from xicm.vla.registration import env_id, register_envs

register_envs()

__all__ = ["env_id", "register_envs"]
