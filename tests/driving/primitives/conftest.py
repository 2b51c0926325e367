import pytest

from regen.core.behavior import Behavior
from regen.core.graph import CausePath, PathEntity


@pytest.fixture
def ground():
    """``ground(template, asset, **properties)``: one actor grounded by the rules around an ego
    template, as (scenario, template, {name: plan})."""
    from regen.driving.grounding.rules import ground_rule_based, plans_for

    def make(template: str, asset: str, **properties: str):
        cause = f"a {asset} does something"
        path = CausePath(behavior=Behavior(text=f"the ego-vehicle does {template}", domain="driving",
                                           params={"ego_template": template}),
                         events=[cause, f"the ego-vehicle does {template}"],
                         entities=[PathEntity(asset=asset, event=cause,
                                              properties={k: [v] for k, v in properties.items()})])
        sc = ground_rule_based(path)
        assert sc.solver.status in ("optimal", "feasible"), sc.solver.conflicts
        t, plans = plans_for(sc)
        return sc, t, {p.name: p for p in plans}

    return make
