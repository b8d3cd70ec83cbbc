"""Attack submissions for the grader (see `attacks.py`)."""
