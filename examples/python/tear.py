import papertear

sim = papertear.Simulation("scenarios/start-inward.json", threads=2)
x = sim.positions                # (n, 3) float64 view of the sheet, no copy
x0 = x.copy()
sim.step()                       # the view follows the sheet (until sim.topology_version changes)
print("moved:", bool(abs(x - x0).max() > 0), "triangles:", sim.triangles.shape)
sim.step(9)
for e in sim.events:             # tear_started / tear_extended / piece_separated
    if e["kind"] != "tear_extended":
        print("frame", e["frame"], e["kind"], "tear", e["tear"])
print("tears", len(sim.tears), "pieces", sim.pieces, "hash", sim.hash)
try:
    papertear.parse_scenario('{"sheet": {"preset": "A4", "triangles": "many"}}', "mine.json")
except papertear.InputError as err:  # a ValueError: "<file>: <json path>: <problem>"
    print("InputError:", err)
