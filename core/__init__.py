"""xicm core: data types, plugin contracts and the X-ICM loop. No heavy imports here."""

__version__ = "0.1.0"
