"""Names vulture (``tests/test_dead_code.py``, confidence 60) reports as unused that are used
in ways it cannot see.  Each line: the name, where it lives, why it is not dead."""

# reduced_models/auto.py: registered by "module:Class" strings (reduced_models.registry.MODELS)
LinearAuto
CBCMAuto
PRBFSMAuto

# cases/schema.py: Analysis.sweep_key, set by keyword in dataclasses.replace (cases/sweep.py)
sweep_key

# reduced_models/mechanism/system.py: _scatter adds into its gout / Hout arguments in place
gout
Hout

# reduced_models/beam/prb.py: the prepared-scene cache, read back through self.__dict__.get
_ready

# reduced_models/beam/prb_tables.py: the settings the 2R fit was made with (documentation data,
# named in the prb-2r card; tests/test_verify_prb.py re-measures the fit)
PRB_2R_FIT

# reports/bench/replay.py: Exudyn simulation settings, set on Exudyn's objects (read by it)
_.endTime
_.numberOfSteps
_.verboseMode
_.spectralRadius
_.automaticStepSize
_.relativeTolerance
_.solverType
_.reuseAnalyzedPattern
_.numberOfThreads
_.computationTime

# reduced_models/beam/prb.py: the chain cache of a solve and its postprocess, read back through
# self.__dict__.get (as _ready above)
_chain

# reports/__init__.py: the module __getattr__ (PEP 562) that imports reports.recommend (from
# reports.verdicts.recommend) on first use; Python calls it, no code does
__getattr__

# numpy: ndarray.flags.writeable = False makes a cached array read-only (bcm_single.stations);
# numpy reads the attribute, no code of ours does
writeable

# cost.Estimate.spent_s: a field read through dataclasses.asdict (the run records it, the
# "Where the time goes" panel reads it from the JSON)
spent_s
