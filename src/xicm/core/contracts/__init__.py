"""The contracts every other layer and every plugin builds on: the data types, the plugin interfaces and
hookspecs, the control spaces, the errors, the config rules and the simulator contract check. Nothing here
imports another layer."""
