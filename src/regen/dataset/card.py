"""The dataset card (``README.md`` of a dataset): what it holds, how many, what was left out and
why, the label set, the QA layers and how each answer is computed, the frame timing. Written
from the built dataset only (no time stamp, no absolute path), so the same runs give the same
card."""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING, Any

from regen.dataset.labels import LABELS
from regen.dataset.qa import HORIZON
from regen.dataset.samples import CAMERA_SIZE, FRAME_OFFSETS

if TYPE_CHECKING:
    from regen.dataset.samples import Sample
    from regen.dataset.write import DatasetResult

LAYER_TEXT = {
    "perception": "which entities are around the ego at the decision moment, where (ahead / behind within "
                  "30 deg of the ego's heading, else left / right; centre distance in metres, e.g. 'ahead, "
                  "20 m') and in what state (moving at v m/s or stationary, on the road / sidewalk / in the "
                  "junction, recorded states such as light_state): from trace.json",
    "prediction": f"what each cause actor does in the {HORIZON:.0f} s after the decision moment (crosses the "
                  "ego's path, moves on, comes towards the ego, starts moving, stops, stays stopped, a state "
                  "that changes): from its trace",
    "planning": "the desired action (the label) and why: the root cause of the causal graph and where the "
                "cause actors are: from the label, graph.json's chain in scenario.json and the trace",
    "counterfactual": "what the ego does if the cause is removed: the reference driver's simulated run without "
                      "the cause (verdict.json causal.without_cause; 'keep_speed' when it shows no reaction), "
                      "and for each what-if of the scenario (regen whatif) the action its simulated ego trace "
                      "shows after the same moment, with the what-if's verdict",
}


def _table(rows: list[tuple[str, Any]], head: tuple[str, str]) -> list[str]:
    return [f"| {head[0]} | {head[1]} |", "|---|---|"] + [f"| {a} | {b} |" for a, b in rows]


def card(result: DatasetResult, samples: list[Sample], runs: list[str]) -> str:
    """The card's Markdown text."""
    by_action = Counter(s.row["action"] for s in samples)
    by_source = Counter(s.row["source"] for s in samples)
    offsets = ", ".join(f"t{dt:+.1f} s" if dt else "t" for dt in FRAME_OFFSETS)
    camera = (f"forward camera pictures ({CAMERA_SIZE[0]}x{CAMERA_SIZE[1]} px, camera_image_k) and "
              if not result.camera_note else "")
    lines = [
        "# ReGen driving vision-language-action dataset", "",
        "Built by `regen dataset` from the run folders: " + ", ".join(f"`{r}`" for r in sorted(runs)) + ".",
        "Each sample is a simulated driving scenario whose cause was shown to cause the ego's behavior, at the "
        "moment the ego decides: three frames, the privileged state of every entity, the desired ego action "
        "and its explanation, with question-answer layers computed from the simulation.", "",
        f"**{result.samples} samples** ({', '.join(f'{n} {k}' for k, n in sorted(by_source.items())) or 'none'}), "
        f"**{result.qa} question-answer pairs**, {len(result.skipped)} candidates left out.", "",
        "## Files", "",
        "- `samples.parquet`: one row a sample: `sample_id`, `pair_id` (a scenario and its what-ifs and test "
        "variants share it), `source` (scenario, whatif, variant), `frame_times`, "
        f"{camera}bird's-eye pictures (`bev_image_k`) as paths relative to this folder, `privileged` (per frame "
        "every entity's name, kind, asset, x, y [m], heading [rad], speed [m/s], length, width, height [m], "
        "states), `action` (the label), `action_evidence` (what the trace shows after the decision moment), "
        "`explanation` (the cause chain and the narrative), `cause_chain`, `narrative`, `cause_entities`, "
        "`verdict_status`, `causal_status`, `instruction`.",
        "- `qa.parquet`: `qa_id`, `sample_id`, `pair_id`, `layer`, `question`, `answer`, `computed_from`, "
        "`options` (the multiple-choice options of the question) and `key` (the correct option, computed like "
        "the answer; empty where the question has no single option), for exact scoring (`regen probe`).",
        "- `images/<sample_id>/bev_k.png`" + (", `camera_k.png`" if not result.camera_note else "") + ": the pictures.",
    ]
    if "llava.json" in result.files:
        lines.append("- `llava.json`: LLaVA-style conversations (`id`, `pair_id`, `image`, `conversations`): "
                     "the frames and the instruction, the action with its explanation, then every QA pair.")
    lines += ["", "Load with `datasets.load_dataset(\"parquet\", data_files={\"train\": \"samples.parquet\"})` "
              "or `pandas.read_parquet(\"samples.parquet\")`.", ""]
    if result.camera_note:
        lines += [f"**No camera pictures**: {result.camera_note}; the `camera_image_k` columns are empty and "
                  "the samples hold the bird's-eye pictures only.", ""]
    lines += ["## Frame timing", "",
              f"The decision moment t is the time the FSM stage holding the ego's first reaction state was "
              f"reached (`verdict.json`, `stages[k].reached_at`). The three frames are at {offsets} (the trace "
              "step nearest to each, never before 0 s); the last one is the decision moment.", "",
              "## Labels", "",
              "The desired ego action is derived from the ego's FSM states (the ego template's reaction states, "
              "else the scenario's ego states) and checked against the trace after the decision moment: 'stop' "
              "needs the ego's speed to reach 0.5 m/s or less, 'slow_down' a drop of at least 2 m/s without "
              "stopping, 'accelerate' a gain of 2 m/s, a lane change 1.5 m sideways to that side, a turn 30 deg. "
              "A trace that contradicts the label leaves the sample out.", ""]
    lines += _table([(f"`{k}`", f"{v} ({by_action.get(k, 0)} samples)") for k, v in LABELS.items()],
                    ("label", "meaning (samples)"))
    lines += ["", "## Question-answer layers", "", "Every answer is computed, never written by a model:", ""]
    lines += [f"- **{k}**: {v}." for k, v in LAYER_TEXT.items()]
    lines += ["", "## Left out", "",
              "A candidate (a run's scenario, each of its what-ifs, each test variant `regen test` recorded) "
              "gives a sample only when its verdict is `verified`, its causal status is `caused` (a variant: "
              "its scenario's) and the trace confirms its label.", ""]
    if result.skipped:
        lines += _table(sorted(result.left_out.items()), ("reason", "candidates"))
        lines += ["", "Each one:", ""]
        lines += [f"- `{s.sample_id}` ({s.source}): {s.reason}" + (f": {s.detail}" if s.detail else "")
                  for s in result.skipped]
    else:
        lines.append("None.")
    return "\n".join(lines) + "\n"


__all__ = ["LAYER_TEXT", "card"]
