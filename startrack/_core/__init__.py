"""startrack's compiled core: the loops numpy cannot express, compiled from Cython when the
package is installed (``setup.py``).

Each ``*.pyx`` module holds the kernels of one stage; the ``_*.pxd`` headers hold the small
inline routines several stages share (sorted-range search, Wahba's problem, order
statistics), so that each is written once. Python calls a kernel once per whole operation
(a frame's centroids, a hypothesis's verification), with the frame's constants in a named
structure, never an array read by offset.
"""
