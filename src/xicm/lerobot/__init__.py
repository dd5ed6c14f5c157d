"""The LeRobot integration: lerobot's own environment, the datasets it writes and reads, its training
and its checkpoints served.

Its isolated, cached environment (env.py, isolated_env.py), the dataset written and read back by lerobot itself (dataset_writer.py driving writer.py / reader.py
in that environment), lerobot's training script on an export (xicm-train-lerobot) and a LeRobot
checkpoint served over openpi's protocol (xicm-serve-lerobot, policy_server.py in the environment)."""
