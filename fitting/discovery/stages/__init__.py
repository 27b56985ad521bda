"""The stages of the per-cycle discovery (`stickslip_fitting.discovery.cycle_workflow`),
each a function of the states before it (`state`):

`prepare` (screening, start, cycle windows) -> `base_fit` (the paper's model, records
judged) -> `rank` (score tests) -> `refit` (significant families and contenders) ->
`sharpen` (far from the data: shapes refined, fits continued and restarted) -> `choose`
(winner and decision) -> `more_effects` (the named effect joins the base; rank, refit,
sharpen and choose again, each earlier effect tested again given the new one, until
nothing significant remains) -> `reweigh` (records tried at full weight) -> `conclude`
(answer, learned correction, result).
"""

from .base_fit import base_fit
from .decide import choose
from .learn import conclude
from .more import more_effects, settled
from .prepare import prepare
from .rank import rank
from .refit import refit
from .reweigh import reweigh
from .sharpen import sharpen
from .state import Base, Choice, Clock, Fits, Prepared, Ranking, Refitted, Reweighed, Step

__all__ = ["Base", "Choice", "Clock", "Fits", "Prepared", "Ranking", "Refitted", "Reweighed",
           "Step", "base_fit", "choose", "conclude", "more_effects", "prepare", "rank",
           "refit", "reweigh", "settled", "sharpen"]
