"""Simulators: scenes, cameras and control behind core's Simulator interface (sapien)."""
