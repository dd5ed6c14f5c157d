"""The built-in plugins, one family per folder, each registered through core's hooks like a third-party one."""
