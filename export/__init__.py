"""`xicm-export`: scripted demonstrations -> a LeRobot dataset, written and read by the real
`lerobot` library in its own cached environment (lerobot_env.py; see docs/DATASET.md)."""
