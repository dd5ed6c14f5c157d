"""What a run leaves behind: the run folder, tracking, transcripts, videos, atomic writes and the demonstration
pool's dataset files."""
