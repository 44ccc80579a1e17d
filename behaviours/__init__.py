"""Built-in behaviour families of cptbt, registered through the ``cptbt.behaviours`` entry points."""
