"""A stand-in grading function for the batch pool's tests (light to import in a worker)."""

import time


def hang(task):
    """Return the task's label at once, or hang for a minute on the task labelled `hangs`."""
    if task[2] == "hangs":
        time.sleep(60)
    return task[2]
