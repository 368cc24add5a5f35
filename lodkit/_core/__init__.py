"""Cython core: half-edge arrays, indexed heap, collapse drivers."""
import os

# GNU OpenMP makes a thread that waits at the end of a parallel loop spin 300,000 times
# before it sleeps.  The pass driver runs a few parallel loops a pass; on a machine where
# other processes hold the cores, those spins took the time the other thread needed to
# finish, and two threads ran twice as long as one (docs/performance.md, "Threads").  A
# short spin keeps the hand-over quick on an idle machine.  Read once, when libgomp loads
# (the first OpenMP module imported: this package's, unless Open3D's came first); a value
# the user set stays.
os.environ.setdefault("GOMP_SPINCOUNT", "10000")
