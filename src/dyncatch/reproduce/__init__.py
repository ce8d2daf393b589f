"""``dyncatch reproduce``: the paper's experiments as cached, resumable stages and a report."""
