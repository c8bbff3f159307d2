"""``python -m models.cli``: the ``hbg`` command."""

from .main import command

command()
