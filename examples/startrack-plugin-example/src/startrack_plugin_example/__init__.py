"""An example startrack matcher living outside startrack: Pyramid limited to its first few
hypotheses, written against startrack's public matcher interface only
(``startrack.matchers``: ``Matcher``, ``MatcherConfig``, ``get_matcher``)."""

from __future__ import annotations

import itertools

from startrack.matchers import Matcher, MatcherConfig, get_matcher


class BudgetPyramidMatcher(Matcher):
    """Pyramid's hypotheses, at most ``budget`` of them per frame.

    The shared verification still accepts or refuses each one, so a smaller budget can
    only leave more frames unsolved, never solve one wrongly: a method a researcher can
    bench against startrack's own with ``startrack compare --methods pyramid,pyramid_budget``.
    """

    name = "pyramid_budget"
    description = "Pyramid limited to its first hypotheses (example plugin)"

    def __init__(self, database, config: MatcherConfig | None = None, *,
                 budget: int = 3) -> None:
        super().__init__(database, config)
        self.inner = get_matcher("pyramid")(database, config)
        self.budget = budget

    def prepare(self) -> None:
        self.inner.prepare()

    def hypotheses(self, obs, diag, screen_rad=None):
        return itertools.islice(self.inner.hypotheses(obs, diag, screen_rad), self.budget)
