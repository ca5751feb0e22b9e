"""The built-in methods' facts, in one table that config, the extractor registry, the report
(tables, plots, overlays, html) and compare read: a method's name, how tables and legends call
it, and how it is drawn. A plug-in method is none of these: it is shown by its own name, in the
styles kept for "other" methods.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

BGR = tuple[int, int, int]


@dataclass(frozen=True)
class MethodFacts:
    name: str  # as configurations, tables and lanes/NAME/ folders name it
    entry: str  # its factory, "module:callable" (extract.registry builds it)
    section: str  # the configuration section holding its parameters
    kernel_groups: tuple[str, ...]  # numba kernel groups it runs (compiled before the workers start)
    after_model: tuple[str, ...]  # its display name after the model's: "SCNN + RONELD w/o PFT"
    word_parts: tuple[str, ...]  # its name alone, in the pieces a stacked header puts on lines
    header: tuple[str, ...]  # its column header lines under the model's spanning header
    pft_label: str | None  # its column in the PFT ablation (Table IV), or None
    ego_lanes_only: bool  # outputs the two ego lanes alone (its official F1 counts outer lanes missed)
    colour: str  # in the figures (matplotlib)
    linestyle: Any
    marker: str
    hatch: str  # its bars in categories.png
    overlay_bgr: BGR  # its lanes in the overlay pictures
    overlay_thickness: int  # at report.overlays.OUTPUT_WIDTH
    overlay_dashed: bool
    overlay_colour: str  # the overlay colour in words, for report.html's note

    @property
    def words(self) -> str:
        """Its name alone, in running text: 'RONELD w/o PFT'."""
        return " ".join(self.word_parts)


BASELINE = MethodFacts(
    "baseline", entry="roneld_eval.extract.baseline:BaselineExtractor", section="baseline",
    kernel_groups=("baseline",), after_model=(), word_parts=("baseline",), header=("baseline",), pft_label=None,
    ego_lanes_only=False, colour="#d62728", linestyle="--", marker="o", hatch="//",
    overlay_bgr=(40, 40, 230), overlay_thickness=4, overlay_dashed=True, overlay_colour="red (dashed)")
RONELD = MethodFacts(
    "roneld", entry="roneld_eval.extract.roneld:with_pft", section="roneld",
    kernel_groups=("roneld",), after_model=("+ RONELD",), word_parts=("RONELD",), header=("+ RONELD",),
    pft_label="w/ PFT",
    ego_lanes_only=True, colour="#2ca02c", linestyle="-", marker="s", hatch="",
    overlay_bgr=(90, 235, 120), overlay_thickness=3, overlay_dashed=False, overlay_colour="green")
RONELD_NOPFT = MethodFacts(
    "roneld-nopft", entry="roneld_eval.extract.roneld:without_pft", section="roneld",
    kernel_groups=("roneld",), after_model=("+ RONELD", "w/o PFT"), word_parts=("RONELD", "w/o PFT"),
    header=("+ RONELD", "w/o PFT"), pft_label="w/o PFT",
    ego_lanes_only=True, colour="#1f77b4", linestyle=":", marker="^", hatch="..",
    overlay_bgr=(235, 200, 60), overlay_thickness=3, overlay_dashed=True, overlay_colour="cyan (dashed)")

METHOD_TABLE: dict[str, MethodFacts] = {facts.name: facts for facts in (BASELINE, RONELD, RONELD_NOPFT)}



@dataclass(frozen=True)
class PaperRoles:
    """Which method plays which part in the paper's tables: the model's own extraction against
    the method (Tables II/III, the accuracy increase, the overlays' pair), and the method without
    preceding-frame tracking (Table IV: the method is the only PFT switch). Report, compare and
    config read the roles here, never a method's name."""

    reference: str
    ours: str
    without_tracking: str


PAPER = PaperRoles(reference=BASELINE.name, ours=RONELD.name, without_tracking=RONELD_NOPFT.name)
PAPER_PAIR = (PAPER.reference, PAPER.ours)
ABLATION_PAIR = (PAPER.without_tracking, PAPER.ours)
# The methods every other one is compared with (gains.csv), when the run has them.
GAIN_REFERENCES = (BASELINE.name, RONELD.name)


def facts_of(method: str) -> MethodFacts | None:
    """A built-in method's facts; None for a plug-in."""
    return METHOD_TABLE.get(method)
