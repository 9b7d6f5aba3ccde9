"""Measurements: reading and checking measured records, their noise floor and their motion phases."""
