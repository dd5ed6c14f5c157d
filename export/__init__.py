"""`xicm-export`: scripted demonstrations -> a LeRobot dataset, written and read by the real
`lerobot` library in its own cached environment (xicm/lerobot/env.py; see docs/DATASET.md)."""
