"""Everything `hadim report` writes into its folder."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from hadim_cli.baselines.tasks import GOAL_RADIUS
from hadim_cli.errors import HadimError
from hadim_cli.plots import timeline_figure
from hadim_cli.report import baselines, measures, tables
from hadim_cli.report import summary as summaries

REFERENCE = "default"


def report_iterations(summary: dict, wanted: list[int] | None) -> list[int]:
    """The iterations of the score table: the wanted ones, else up to 5 spread over the
    evaluated iterations (always the first and the last)."""
    if wanted:
        return wanted
    evaluated = sorted({int(it) for cfg in summary["configs"].values()
                        for by_it in cfg.values() for it in by_it})
    if len(evaluated) <= 5:
        return evaluated
    picks = {evaluated[round(i * (len(evaluated) - 1) / 4)] for i in range(5)}
    return sorted(picks)


def write_report(store, sweep: str | Sequence[str], out: Path,
                 at: list[int] | None = None) -> list[Path]:
    """summary.json, tables.md, competence.png (if the learner's runs were evaluated),
    timelines/RUN.png of every learner run, and with baseline runs fig5.png (paper Fig. 5:
    with both measures when the runs have them, `report.measures`) into `out`, from one
    sweep or several together; returns the files written."""
    from hadim_cli.plots import comparison_figure

    sweeps = [sweep] if isinstance(sweep, str) else list(sweep)
    groups = merged_groups(store, sweeps)
    sweep = " + ".join(sweeps)
    configs = {label: store.get_run(names[0]).config for label, names in groups.items()}
    learner = {label: names for label, names in groups.items()
               if not summaries.is_baseline(configs[label])}
    try:
        (out / "timelines" if learner else out).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise HadimError(f"cannot write the report to {out}: {exc.strerror or exc}") from None
    summary = summaries.build_summary(store, groups)
    written = [out / "summary.json", out / "tables.md"]
    evaluations = {label: [store.evaluations(n) for n in names] for label, names in groups.items()}
    if any(evs for label in learner for evs in evaluations[label]):  # else: trained with no eval
        written.append(out / "competence.png")
        comparison_figure({label: evaluations[label] for label in learner}, written[-1],
                          tables.TASKS)
    parts = [f"# Sweep {sweep}", "## Scores (mean ± std over seeds)",
             tables.score_table(summary, report_iterations(summary, at))]
    if len(learner) < len(groups):
        fig5 = _fig5_groups(configs, evaluations)
        summary["comparison"] = baselines.comparison_summary(fig5, GOAL_RADIUS)
        parts += ["## Reinforcement-learning comparison (paper §5.3, Fig. 5)",
                  baselines.comparison_table(fig5, GOAL_RADIUS)]
        both = measures.group_curves(store, _fig5_names(configs, groups))
        if both:
            summary["claims"] = measures.claims_summary(both)
            parts += ["## The paper's claims, both measures (score / episode success)",
                      measures.claims_table(both)]
        if both or any(evs for runs in fig5.values() for evs in runs):
            written.append(out / "fig5.png")
            _fig5(both, fig5, written[-1])
    for names in learner.values():
        for name in names:
            path = out / "timelines" / f"{name}.png"
            timeline_figure(store.events(name), store.get_run(name).iterations, path)
            written.append(path)
    written[0].write_text(json.dumps(summary, indent=1, sort_keys=True))
    if learner:
        reference = REFERENCE if REFERENCE in learner else next(iter(learner))
        run_md, counts = tables.run_table(store, learner[reference])
        parts += ["## The paper's targets", tables.target_table(summary, reference),
                  f"## H at the end, per seed ({reference})", run_md,
                  tables.counts_line(counts)]
    written[1].write_text("\n\n".join(parts) + "\n")
    return written


def merged_groups(store, sweeps: Sequence[str]) -> dict[str, list[str]]:
    """The groups of several sweeps together; a sweep with no runs yet is left out when
    others have some."""
    groups: dict[str, list[str]] = {}
    for name in sweeps:
        try:
            found = summaries.sweep_groups(store, name)
        except HadimError:
            if len(sweeps) == 1 or store.sweep_settings(name) is None:
                raise
            continue
        for label, names in found.items():
            groups.setdefault(label, []).extend(names)
    if not groups:
        raise HadimError(f"the sweeps {', '.join(sweeps)} have no runs yet: run them first")
    return groups


def _fig5(both: dict, fig5: dict, out: Path) -> None:
    """Both measures when the runs have them, else the budgeted scores."""
    from hadim_cli.plots import comparison_figure

    if both:
        measures.measures_figure(both, out)
    else:
        comparison_figure(fig5, out, tables.TASKS, log_x=True)


def _fig5_names(configs: dict[str, dict], groups: dict[str, list[str]]) -> dict[str, list]:
    """The sweep's run names by the paper's legend (as `_fig5_groups`)."""
    out: dict[str, list] = {}
    for label, names in groups.items():
        out.setdefault(baselines.group_label(configs[label], label), []).extend(names)
    return out


def _fig5_groups(configs: dict[str, dict], evaluations: dict[str, list]) -> dict[str, list]:
    """The sweep's runs as the paper's legend: algorithm (reward), and the learner's configs."""
    fig5: dict[str, list] = {}
    for label, runs in evaluations.items():
        fig5.setdefault(baselines.group_label(configs[label], label), []).extend(runs)
    return fig5
