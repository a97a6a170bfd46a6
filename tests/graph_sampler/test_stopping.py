"""Issue 28: a run goes on until -n new variants, the iteration cap, an exhausted pool or the
graceful time limit, and says which stopped it."""
import pytest

from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions

# small budgets: the stopping rules do not depend on how many attempts an iteration has
OPTS = SamplerOptions(attempts_per_shape=16, min_attempts=128, max_attempts=256, batch_size=16, counts="grammar")


@pytest.fixture(scope="module")
def sampler(kit):
    def make():
        return GraphSampler(rules=kit.rules(), examples=kit.examples(), seed=7, options=OPTS, workers=1)
    return make


def test_n_reached_iteration_cap_and_time_limit_are_told_apart(sampler):
    s = sampler()
    shapes = list(s.run(2, 10))
    assert len(shapes) == 2 and s.stopped == "n"
    s = sampler()
    shapes = list(s.run(10_000, 1))
    assert s.stopped in ("iterations", "exhausted") and len(shapes) < 10_000
    capped = s.stopped
    # the time limit, polled between batches: nothing more is made once it is up
    s = sampler()
    calls = []

    def time_is_up():
        calls.append(1)
        return len(calls) > 2

    shapes = list(s.run(10_000, 10, time_is_up=time_is_up))
    assert s.stopped == "time" and len(shapes) < 10_000
    assert capped != "time"


def test_more_iterations_make_more_until_the_pool_is_exhausted(sampler):
    one, many = sampler(), sampler()
    a = list(one.run(10_000, 1))
    b = list(many.run(10_000, 3))
    assert len(b) >= len(a)
    assert many.stopped in ("iterations", "exhausted")
    assert [s.key for s in b[:len(a)]] == [s.key for s in a]  # a longer run extends a shorter one
