"""mkdocs hook: puts the tables generated from planarkin's registries into the reference pages.

A page writes a marker ``<!-- planarkin: NAME -->`` on a line of its own; NAME is one of the
generators below (planarkin/docs.py). Nothing in these tables is copied by hand."""

import re

from planarkin import docs

GENERATORS = {
    "keys": docs.keys_table,
    "kinds": docs.kinds_table,
    "kinds-reference": docs.kinds_reference,
    "options": docs.options_table,
    "reactions": docs.reaction_signs,
}
MARKER = re.compile(r"^<!-- planarkin: ([\w-]+) -->$", re.M)


def on_page_markdown(markdown, page, config, files):
    def sub(m):
        try:
            return GENERATORS[m.group(1)]()
        except KeyError:
            raise ValueError(f"{page.file.src_path}: unknown generated table "
                             f"{m.group(1)!r}") from None
    return MARKER.sub(sub, markdown)
