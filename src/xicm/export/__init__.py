"""`xicm-export`: scripted demonstrations recorded at the control rate -> a LeRobot dataset.

The dataset is written and read by the real `lerobot` library in its own cached environment
(xicm/lerobot/env.py; see docs/DATASET.md)."""
