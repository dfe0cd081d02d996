# Pairing of observed and projected catalog positions (implemented in _nearest.pyx): the
# nearest catalog star of each observed star, and every pair within a radius, on a grid of
# about one catalog star per cell, so that a frame costs O(n + m) and not O(n m).


cdef class Pairs:
    """Every (observed, catalog) pair within a radius, sorted by observed then catalog
    index. ``start[i]:start[i + 1]`` are observed star i's pairs (n + 1 offsets)."""
    cdef long long[::1] obs
    cdef long long[::1] cat
    cdef double[::1] d2
    cdef long long[::1] start


cdef class Nearest:
    """One-to-one nearest pairs: observed ``obs[k]`` (ascending) with catalog ``cat[k]``."""
    cdef long long[::1] obs
    cdef long long[::1] cat


cdef class NearestScratch:
    """The working buffers of nearest_matches and the pairings, kept by a
    frame from one call to the next (each call allocating its own cost more than the
    pairing of tens of stars): per observed star its nearest catalog star and squared
    distance, per catalog star the observed star that keeps it, the catalog grid's cell
    offsets, cells and order, and the pairs found. Their lengths only grow; a call uses
    the first values it needs."""
    cdef long long[::1] nearest
    cdef double[::1] dist2
    cdef long long[::1] owner
    cdef long long[::1] start
    cdef long long[::1] cell
    cdef long long[::1] order
    cdef long long[::1] pair_obs  # pairs_in's pairs (its Pairs are views of these)
    cdef long long[::1] pair_cat
    cdef double[::1] pair_d2
    cdef long long[::1] pair_start


cdef Pairs pairs_in(const double[::1] ox, const double[::1] oy, const double[::1] x,
                    const double[::1] y, double radius2, NearestScratch scratch)

cdef Pairs pairs_and_crowded(const double[::1] ox, const double[::1] oy,
                             const double[::1] x, const double[::1] y, double radius2,
                             double resolve2, NearestScratch scratch,
                             unsigned char[::1] crowded)

cdef Pairs pairs_within(const double[::1] ox, const double[::1] oy, const double[::1] x,
                        const double[::1] y, double radius2,
                        NearestScratch scratch=*)

cdef Nearest nearest_matches(const double[::1] ox, const double[::1] oy,
                             const double[::1] cx, const double[::1] cy, double radius_px,
                             NearestScratch scratch=*)
