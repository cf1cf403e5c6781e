"""``campaign``: Monte-Carlo campaigns of a scene with dispersed parameters, and fleet replay,
on Dask.

``campaign SPEC --out DIR`` reads a YAML spec (:mod:`~.spec`: scene, runs, duration, output
times, dispersions of inertia, attitude, rates, effect parameters and commanded torques),
draws each run's parameters from its own stream of one root seed (:mod:`~.sampling`, over
:mod:`rigid_body_attitude.core.dynamics.dispersions`), runs chunks of runs on the batch engine
(:mod:`~.runner`, :class:`~rigid_body_attitude.core.dynamics.batch.SceneBatch`) as Dask tasks
(:mod:`~.engine`: a local cluster by default, ``--scheduler ADDRESS`` for an existing one),
keeps each finished chunk as Parquet (:mod:`~.storage`: an interrupted campaign resumes),
and summarises percentiles of the metrics over time (:mod:`~.statistics`, :mod:`~.plot`).
``campaign replay BAGS... --out DIR`` replays many bags as Dask tasks into one table
(:mod:`~.fleet`). Every run's result is the same whatever the chunking and the workers.

Python API::

    spec = load_spec('config/campaigns/gravity_gradient_pointing.yaml')
    result = run_campaign(spec, 'out', workers=2)      # or serial=True, scheduler='tcp://...'
    runs = read_runs('out', spec)                      # every run's parameters and results
"""

from rigid_body_attitude.tools.campaign.cli import main
from rigid_body_attitude.tools.campaign.engine import (
    CampaignError, CampaignResult, chunk_runs, dask_client, local_cluster,
    LOCAL_CLUSTER_CONFIG, read_runs, run_campaign)
from rigid_body_attitude.tools.replay.fleet import find_bags, replay_fleet, replay_one
from rigid_body_attitude.tools.campaign.runner import FAILURE_REASONS, run_chunk
from rigid_body_attitude.tools.campaign.sampling import RunParameters, sample_runs
from rigid_body_attitude.tools.campaign.spec import (
    CampaignSpec, load_spec, spec_from_mapping, SpecError)
from rigid_body_attitude.tools.campaign.statistics import METRICS

__all__ = ['CampaignError', 'CampaignResult', 'CampaignSpec', 'FAILURE_REASONS',
           'LOCAL_CLUSTER_CONFIG', 'METRICS',
           'RunParameters', 'SpecError', 'chunk_runs', 'dask_client', 'find_bags',
           'load_spec', 'local_cluster', 'main', 'read_runs', 'replay_fleet', 'replay_one',
           'run_campaign', 'run_chunk', 'sample_runs', 'spec_from_mapping']
