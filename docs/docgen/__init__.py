"""The docs' generated parts, one module per job (`docs/hooks.py` is MkDocs' entry to them):

| module | job |
|---|---|
| `results` | the results reader: a results file (`tether_gym.evaluation.results_file`) or a |
| | pretrained agent's card as env, arguments, seed and agents |
| `tables` | the results tables' macros, and the ladder's ids |
| `family_pages` | an env page's reference part, from its family record |
| `cli_reference` | a console script's command-line reference, from its `build_parser` |
| `docstring_tables` | the docstrings' tables one row per entry (a griffe extension) |
| `macros` | the placeholders: `{{ macro(literal arguments) }}` rendered |
| `readme` | the README's generated blocks rewritten (`python docs/hooks.py --readme`) |
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
"""The repository: results paths in placeholders are relative to it."""
