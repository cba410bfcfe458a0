// Shareable scenarios: the front page's address can name a terrain, gait, planner and compare mode,
//   /?terrain=stepping_stones&gait=walk&planner=contactnet&compare=contactnet,fixed
//   /?terrain=random&removed=80&seed=3&gait=trot&planner=heuristic
// and the page applies it through the REST API when it opens (only what differs from the live session, so
// reloading the page does not restart the robot). A link always describes the whole scenario: without
// `compare` it means compare mode off. The Share button builds such a link from State.scenario.
"use strict";

const Scenario = (() => {
  const KEYS = ["terrain", "removed", "seed", "gait", "planner", "compare"];
  const NAME = /^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$/;
  const INTEGER = /^[0-9]{1,10}$/;

  /** The scenario named by a query string: {terrain, removed, seed, gait, planner, compare: [..]} with only
   *  the keys given (compare always: [] when absent), plus `problems` (one line per value not understood);
   *  null when the query names no scenario. */
  function fromQuery(search) {
    const query = new URLSearchParams(search);
    if (!KEYS.some((key) => query.has(key))) return null;
    const wanted = { compare: [], problems: [] };
    for (const key of ["terrain", "gait", "planner"]) {
      if (!query.has(key)) continue;
      const value = query.get(key).trim();
      if (NAME.test(value)) wanted[key] = value;
      else wanted.problems.push(`${key}=${JSON.stringify(value)} is not a name`);
    }
    for (const key of ["removed", "seed"]) {
      if (!query.has(key)) continue;
      const value = query.get(key).trim();
      if (INTEGER.test(value)) wanted[key] = Number(value);
      else wanted.problems.push(`${key}=${JSON.stringify(value)} is not a whole number`);
    }
    const compare = (query.get("compare") || "").trim();
    if (compare && compare !== "off") {
      const names = compare.split(",").map((name) => name.trim());
      if (names.length === 2 && names.every((name) => NAME.test(name))) wanted.compare = names;
      else wanted.problems.push(`compare=${JSON.stringify(compare)} must be two planner names, e.g. contactnet,fixed`);
    }
    return wanted;
  }

  /** The query without the scenario's keys (what the 3D view is given, e.g. fixedDpr, token). */
  function others(search) {
    const query = new URLSearchParams(search);
    for (const key of KEYS) query.delete(key);
    return query;
  }

  function compareList(value) {
    if (Array.isArray(value)) return value.filter(Boolean);
    if (typeof value === "string" && value) return value.split(",");
    return [];
  }

  /** What the live session runs now, in the scenario's terms (State.scenario when the server has it). */
  function current(state) {
    if (state.scenario) return Object.assign({}, state.scenario, { compare: compareList(state.scenario.compare) });
    const compare = state.compare ? [state.planner, ...state.compare.map((c) => c.planner)] : [];
    return { terrain: state.terrain, removed: null, seed: null, gait: state.gait, planner: state.planner, compare };
  }

  /** Apply `wanted` (from `fromQuery`) to the live session through `api`; `say(text, level)` reports each
   *  refusal. Returns the number of requests that failed. */
  async function apply(wanted, state, api, say) {
    let failed = 0;
    const post = async (what, path, body) => {
      try {
        await api(path, { method: "POST", body: JSON.stringify(body) });
      } catch (e) {
        failed += 1;
        say(`Shared link: ${what} refused (${e.message})`, "error");
      }
    };
    for (const problem of wanted.problems) say(`Shared link: ${problem}; ignored`, "warning");
    const now = current(state);
    if (wanted.terrain) {
      const random = wanted.terrain === "random";
      const body = { name: wanted.terrain };
      if (random) {
        body.removed = wanted.removed ?? 0;
        body.seed = wanted.seed ?? 0;
      }
      const same = now.terrain === wanted.terrain && (!random || (now.removed === body.removed && now.seed === body.seed));
      if (!same) await post(`terrain ${wanted.terrain}`, "/api/session/terrain", body);
    }
    const settings = {};
    if (wanted.gait && wanted.gait !== now.gait) settings.gait = wanted.gait;
    if (wanted.planner && wanted.planner !== now.planner) settings.planner = wanted.planner;
    if (Object.keys(settings).length) await post(Object.keys(settings).join(" and "), "/api/settings", settings);
    if (wanted.compare.join(",") !== now.compare.join(",")) {
      const what = wanted.compare.length ? `compare ${wanted.compare.join(" vs ")}` : "compare off";
      await post(what, "/api/compare", { planners: wanted.compare });
    }
    return failed;
  }

  /** The link that opens `scenario` (State.scenario) on this server, or null when its terrain is an unsaved
   *  edit (a link can only name a saved terrain). */
  function link(scenario, origin) {
    if (!scenario || !scenario.terrain) return null;
    const query = new URLSearchParams();
    query.set("terrain", scenario.terrain);
    if (scenario.terrain === "random") {
      query.set("removed", String(scenario.removed ?? 0));
      query.set("seed", String(scenario.seed ?? 0));
    }
    if (scenario.gait) query.set("gait", scenario.gait);
    if (scenario.planner) query.set("planner", scenario.planner);
    const compare = compareList(scenario.compare);
    if (compare.length) query.set("compare", compare.join(","));
    return `${origin}/?${query.toString().replaceAll("%2C", ",")}`;
  }

  return { KEYS, fromQuery, others, apply, link, current };
})();
