"""What the Snakemake workflow needs beyond the science: a job's log and provenance and the
allocator preload (:mod:`.jobs`), the console's one line per job (:mod:`.console`) and ``pih
status`` (:mod:`.status`). May import :mod:`pih.study` and everything below it; building the job
graph imports no Drake."""
