"""An env page's reference part, from the family record (`tether_gym.families`): its ids and
entry points, its agents with their notes, its baselines and yardstick, and its backends. A
family added to the record gets the same section on its page by one placeholder,
`{{ family_reference("NAME") }}`."""

from __future__ import annotations

from tether_gym.families import FAMILIES, Family


def _family(name: str) -> Family:
    """The family named `name`; ValueError naming the families for another name."""
    for env_family in FAMILIES:
        if env_family.name == name:
            return env_family
    raise ValueError(f"no env family {name!r}: one of {[f.name for f in FAMILIES]}")


def family_reference(name: str) -> str:
    """The Markdown of family `name`'s reference: ids, agents, baselines, backends."""
    env_family = _family(name)
    ids = len(env_family.ids)
    others = f" and {ids - 1} more" if ids > 1 else ""
    baseline_of = {agent: label for label, agent in env_family.baselines.items()}
    lines = [
        f"Registered ids: `{env_family.env_id}`{others}; `gym.make`'s entry point "
        f"`{env_family.entry_point}`, `gym.make_vec`'s `{env_family.vector_entry_point}`.",
        "",
        "| agent (`tether-evaluate --agents`) | what it is | baseline |",
        "|---|---|---|",
    ]
    for agent in env_family.agents:
        label = baseline_of.get(agent, "")
        if label == env_family.yardstick:
            label += " (the training runs' yardstick)"
        lines.append(f"| `{agent}` | {env_family.agent_notes.get(agent, '')} | {label} |")
    if env_family.backends:
        lines += ["", "| backend | extra | ids | trained by |", "|---|---|---|---|"]
        for backend in env_family.backends:
            first = next(iter(backend.ids))
            trained = (f"`tether-train --backend {backend.name}`"
                       if backend.gymnax_entry_point else "-")  # fmt: skip
            lines.append(f"| {backend.name} | `{backend.extra}` | {len(backend.ids)} (`{first}`"
                         f"{' ...' if len(backend.ids) > 1 else ''}) | {trained} |")  # fmt: skip
    return "\n".join(lines) + "\n"
