"""Models against measurements: replay a record, fit effects, diagnose what is missing."""
