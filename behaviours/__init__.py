"""Built-in behaviour families of cptbt, registered as cptbt.behaviours entry points."""
