# Pairing of observed and projected catalog positions (implemented in nearest.pyx): the
# nearest catalog star of each observed star, and every pair within a radius, on a grid of
# about one catalog star per cell, so that a frame costs O(n + m) and not O(n m).


cdef struct Grid:
    # Square cells of side ``size`` (``inv``: 1 / size) from (x0, y0), nx by ny.
    double x0, y0, size, inv
    Py_ssize_t nx, ny


cdef struct Cells:
    # Positions bucketed in a Grid's cells: ``start`` offsets, positions by cell (in a
    # NearestScratch's or a PointGrid's buffers: a struct of pointers costs no object per
    # call); ``ok``: False where the grid cannot take the positions. The pointers hold no
    # reference: they stay valid while those arrays do, a PointGrid's for its lifetime
    # (it keeps them), a scratch's only until its next bucketing (which may regrow them),
    # so a scratch's Cells lives within the one pairing call that bucketed it.
    Grid grid
    long long* start
    long long* order
    bint ok


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
    """The working buffers of nearest_matches and the pairings, kept by a frame from one
    call to the next (each call allocating its own cost more than the
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

cdef class PointGrid:
    """Fixed positions (a frame's observed stars) bucketed once, the non-finite left out,
    so that the stars projected at each attitude can each look up their nearby ones."""
    cdef Cells cells
    cdef long long[::1] start  # the buffers ``cells`` points into
    cdef long long[::1] order


cdef struct Reach:
    # Which projected catalog stars claim observed stars: the valid ones in the window
    # lo_x <= x <= hi_x, lo_y <= y <= hi_y, each the observed stars within ``radius`` px.
    double lo_x, hi_x, lo_y, hi_y
    double radius


cdef PointGrid point_grid(const double[::1] x, const double[::1] y)

cdef Py_ssize_t claim_nearest(PointGrid grid, const double[::1] ox, const double[::1] oy,
                              const double[::1] x, const double[::1] y,
                              const unsigned char[::1] valid, Reach reach,
                              long long[::1] nearest, double[::1] dist2, Reach wide,
                              long long[::1] wide_nearest, double[::1] wide_dist2,
                              Py_ssize_t* wide_in) noexcept

cdef Nearest one_to_one(const long long[::1] nearest, const double[::1] dist2,
                        long long[::1] owner)

cdef Nearest nearest_matches(const double[::1] ox, const double[::1] oy,
                             const double[::1] cx, const double[::1] cy, double radius_px,
                             NearestScratch scratch=*)
