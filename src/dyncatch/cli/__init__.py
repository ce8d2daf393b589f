"""The ``dyncatch`` command line: each sub-command is a dataclass read by tyro."""
