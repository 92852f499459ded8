"""What a reader sees of the analysis (:mod:`pih.analysis`): the planning summary files, alike
for the workflow and ``pih aggregate`` (:mod:`.planning_summary`), the at-a-glance Markdown
beside the paper's numbers (:mod:`.summary`) and the figures (:mod:`.plots`). No Drake.
May import :mod:`pih.analysis` and everything below it."""
