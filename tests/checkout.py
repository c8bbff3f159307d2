"""Where the tests run: the root of the checkout (its packages, README, notebooks)
and the tests' own folder, for tests that start Python in a new process."""

from pathlib import Path

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent
