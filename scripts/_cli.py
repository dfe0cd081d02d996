"""The command-line options several scripts share, each declared (type, meaning) in one place
so that the same flag means the same thing in every script that takes it."""

from __future__ import annotations

import argparse


def script_parser(doc: str) -> argparse.ArgumentParser:
    """A script's argument parser, described by the first line of its docstring.

    Parameters
    ----------
    doc : str
        The script's ``__doc__``.

    Returns
    -------
    argparse.ArgumentParser
    """
    return argparse.ArgumentParser(description=doc.splitlines()[0])


def add_frames(ap: argparse.ArgumentParser, frames: int, seed: int | None = None,
               frames_help: str | None = None) -> None:
    """``--frames`` (how many frames a run makes) and, given a default, ``--seed`` (of the
    frames' random attitudes and noise).

    Parameters
    ----------
    ap : argparse.ArgumentParser
    frames : int
        The default of ``--frames``.
    seed : int, optional
        The default of ``--seed``; None: the script takes no ``--seed``.
    frames_help : str, optional
        What ``--frames`` counts, when it is more than "frames".
    """
    ap.add_argument("--frames", type=int, default=frames, help=frames_help)
    if seed is not None:
        ap.add_argument("--seed", type=int, default=seed)


def add_camera(ap: argparse.ArgumentParser, noise_px: float, fov: float = 20.0,
               size: int = 1024) -> None:
    """``--fov``, ``--size`` and ``--noise-px``: the square camera a synthetic frame is made
    with and the centroid noise on its stars.

    Parameters
    ----------
    ap : argparse.ArgumentParser
    noise_px : float
        The default 1-sigma centroid noise, px.
    fov : float
        The default field width, deg.
    size : int
        The default image width = height, px.
    """
    ap.add_argument("--fov", type=float, default=fov, help="field width, deg")
    ap.add_argument("--size", type=int, default=size, help="image width = height, px")
    ap.add_argument("--noise-px", type=float, default=noise_px,
                    help="1-sigma centroid noise, px")


def add_paper_passes(ap: argparse.ArgumentParser, frames: int, raw_frames: int,
                     methods: str) -> None:
    """The options of a paper's runs: the verified bench pass, the raw (unverified) pass
    and the matchers run.

    Parameters
    ----------
    ap : argparse.ArgumentParser
    frames, raw_frames : int
        The defaults of ``--frames`` and ``--raw-frames`` (frames per condition).
    methods : str
        The default of ``--methods``, comma-separated.
    """
    add_frames(ap, frames, frames_help="verified (bench) frames per condition")
    ap.add_argument("--raw-frames", type=int, default=raw_frames,
                    help="frames per condition of the raw (unverified) pass")
    ap.add_argument("--methods", default=methods,
                    help="comma-separated matcher names (variants included)")


def add_repeats(ap: argparse.ArgumentParser, repeats: int) -> None:
    """``--repeats``: how many timed runs a benchmark's median is taken over.

    Parameters
    ----------
    ap : argparse.ArgumentParser
    repeats : int
        The default.
    """
    ap.add_argument("--repeats", type=int, default=repeats,
                    help="timed runs the median is taken over")
