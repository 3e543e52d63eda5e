"""The decision table of docs/guide_estimators.md, from the committed CSVs under bench/results/
(scripts/doc_tables.py writes it between its markers). Each row: a use, the estimator to
take, and the measured figure behind it with its CSV."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench", "results")
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from readme_measured import rows, sci, span, times  # noqa: E402


def converge_rows():
    import converge_tables
    csvs = [os.path.join(RESULTS, "converge", "%s_convergence.csv" % m) for m in ("polyester", "cotton", "satin")]
    return converge_tables.measures(csvs, converge_tables.tails_of(csvs), 1024)


def light_rows():
    import light_tables
    return light_tables.measures([os.path.join(RESULTS, "converge_light", "%s_convergence.csv" % m)
                                  for m in ("polyester", "cotton", "satin", "paper")], 1024)


def render_rows():
    import render_tables
    return [render_tables.row_for(os.path.join(RESULTS, "render", "%s_%s" % (f, s)))
            for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")]


def equal_time(scene, fiber, estimator):
    """An estimator's relative MSE at equal time in a committed render."""
    import render_tables
    got, _ = render_tables.read_render(os.path.join(RESULTS, "render", "%s_%s" % (fiber, scene)))
    return next(float(r["rel_mse"]) for r in got if r["mode"] == "equal_time" and r["estimator"] == estimator)


def room_rows():
    import room_tables
    return [room_tables.row_for(os.path.join(RESULTS, "render", "%s_room" % f))
            for f in ("silk", "cotton", "wool", "polyester")]


def peer_ratios():
    """Per RGL material under constant light: mis_tab's (the mixture with its earned share) variance per sample
    over the file's own sampler's, median over the views."""
    by = {}
    for r in rows("sampling_peers.csv"):  # the RGL materials under constant light
        if r.get("lighting", "constant") == "constant":
            by.setdefault(r["material"], {}).setdefault(r["theta_o_deg"], {})[r["sampler"]] = r
    by = {m: v for m, v in by.items() if all("rgl" in x for x in v.values())}
    out = {}
    for mat, views in by.items():
        x = sorted(float(v["mis_mixture"]["relvar"]) / float(v["rgl"]["relvar"]) for v in views.values())
        out[mat] = x[len(x) // 2] if len(x) % 2 else 0.5 * (x[len(x) // 2 - 1] + x[len(x) // 2])
    return out


def sky_product_ratios():
    """Per RGL material under the sky: mis_product's variance per sample over mis_light_rgl's, median over views."""
    by = {}
    for r in rows("sampling_peers.csv"):
        if r.get("lighting", "constant") != "constant":
            by.setdefault(r["material"], {}).setdefault(r["theta_o_deg"], {})[r["sampler"]] = r
    out = {}
    for mat, views in by.items():
        x = sorted(float(v["mis_product"]["relvar"]) / float(v["mis_light_rgl"]["relvar"])
                   for v in views.values() if "mis_product" in v and "mis_light_rgl" in v)
        if x:
            out[mat] = x[len(x) // 2] if len(x) % 2 else 0.5 * (x[len(x) // 2 - 1] + x[len(x) // 2])
    return out


def resolved_ratios():
    """Per RGL material: the resolved grid fitted to 2 % L1 against the file's sampler (rgl_resolve.csv)."""
    return {r["material"]: float(r["is_mixture_over_rgl_median"]) for r in rows("rgl_resolve.csv")
            if r["grid"] == "resolved_t2" and r["is_mixture_over_rgl_median"]}


def choice():
    c = converge_rows()
    const = [x for x in c if x["scene"] == "constant"]
    sky = [x for x in c if x["scene"] == "sky"]
    weight = max(x["is_max_weight"] for x in c if x["is_max_weight"] is not None)
    li = light_rows()
    gmm_vs_cdf = [x["mlg_fewer"] / x["mlc_fewer"] for x in li]
    rr = render_rows()
    gmm = [equal_time(s, f, "mis_light_gmm") / equal_time(s, f, "mis_light_cdf")
           for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")]
    prod = [x["product_vs_cdf"] for x in rr if x["product_vs_cdf"]]
    room = room_rows()
    room_gmm = [x["mis_light_gmm"] / x["mis_light_cdf"] for x in room]
    guided = [x[e] / x["mis_light_cdf"] for x in room for e in ("guided", "guided_product")]
    peers = peer_ratios()
    file_wins = sorted(m for m in peers if peers[m] > 1)
    mix_wins = sorted(m for m in peers if peers[m] <= 1)
    resolved = resolved_ratios()
    sky_prod = sky_product_ratios()
    return [
        "| use | take | measured | CSV |", "|---|---|---|---|",
        "| BSDF only, smooth light | `mis_tab` | %s fewer samples than uniform for its error; a sample costs %s a uniform one "
        "| [converge/](../bench/results/converge/) |" % (
            span([x["mis_fewer"] for x in const]), span([x[k] for x in const for k in ("cost_mis",)])),
        "| BSDF only, memory no object | `cdf_tab` | exact under constant light; as large as the table slice "
        "| [converge/](../bench/results/converge/) |",
        "| BSDF only, under a sun | add light sampling (next rows) | `mis_tab` gains only %s over uniform "
        "| [converge/](../bench/results/converge/) |" % span([x["mis_fewer"] for x in sky]),
        "| Never alone | not `is_tab` | largest f/pdf over the integral up to %s; `mis_tab` bounds it "
        "| [converge/](../bench/results/converge/) |" % sci(weight),
        "| Lights, one shading point | `mis_product` | %s fewer samples than `mis_light_cdf`; `mis_light_gmm` "
        "needs %s `mis_light_cdf`'s samples | [converge_light/](../bench/results/converge_light/) |" % (
            span([x["mp_vs_base"] for x in li]), span([1 / g for g in gmm_vs_cdf])),
        "| Lights, rendered image | `mis_light_cdf` (table kept) or `mis_light_gmm` | `mis_light_gmm` has %s "
        "`mis_light_cdf`'s error at equal time; `mis_product` %s | [render/](../bench/results/render/) |" % (
            span(gmm), span(prod)),
        "| Indirect light (the room) | `mis_light_gmm` | %s `mis_light_cdf`'s error at equal time; guided %s "
        "| [render/](../bench/results/render/) |" % (span(room_gmm), span(guided)),
        "| RGL file at hand, BSDF only | `mis_tab` where it wins, else the file's own sampler or the mixture of a "
        "resolved grid | at the default grid the file's sampler wins on %s; `mis_tab` wins on %s; on resolved grids "
        "fitted to 2 %% L1 the mixture has %s its variance "
        "| [sampling_peers.csv](../bench/results/sampling_peers.csv), [rgl_resolve.csv](../bench/results/rgl_resolve.csv) |" % (
            ", ".join("%s (%sx)" % (m, times(peers[m])) for m in file_wins) or "-",
            ", ".join("%s (%sx)" % (m, times(peers[m])) for m in mix_wins) or "-",
            ", ".join("%sx (%s)" % (times(v), m) for m, v in sorted(resolved.items())) or "-"),
        "| RGL file at hand, with lights | `mis_product` | %s `mis_light_rgl`'s variance (light sampling with the "
        "file's sampler), median over views under the sky | [sampling_peers.csv](../bench/results/sampling_peers.csv) |" % (
            ", ".join("%sx (%s)" % (times(v), m) for m, v in sorted(sky_prod.items()))),
        "| Stand-in, no table kept | `mis_light_gmm` on the mixture | image within %s of the table's (4 x 4 "
        "blocks), %s smaller | [render/](../bench/results/render/) |" % (
            span([x["stand_in_4x4"] for x in rr], "%"), span([x["memory"] for x in rr])),
    ]
