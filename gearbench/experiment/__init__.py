"""Experiment and plant files: YAML in, validated typed objects out (SPEC section 3)."""
from ..errors import ConfigError
from .files import (Experiment, experiment_from_dict, load_experiment, load_plant,
                    plant_from_dict, read_yaml, validate_experiment_dict, validate_plant_dict)

__all__ = ["ConfigError", "Experiment", "experiment_from_dict", "load_experiment", "load_plant",
           "plant_from_dict", "read_yaml", "validate_experiment_dict", "validate_plant_dict"]
