"""From config to a live run: the plugin registry, the run builder, the config schema and its checks, the console
scripts and the eval and collect jobs, instructions, literal-key refusal and seeding."""
