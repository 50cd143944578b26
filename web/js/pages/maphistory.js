// One robot's map history: the lineage timeline (parent → child, coloured by review state) and every version's
// figures; a version opens its review page.
import { ApiError, getJson, postAsEngineer } from '../api.js';
import { card, emptyState, go, h, num, setState, time } from '../ui.js';
import { approvalBadge, lineageLegend, lineageTimeline, originLabel, robotMapsPath, sameMapAs, versionHash } from '../maphistory.js';

export async function render(main, { args, isCurrent }) {
  const robotId = args[0];
  // A robot with no history yet (one whose owner imports its first export here) has an empty page, not an error.
  const noHistory = (error) => {
    if (error instanceof ApiError && error.status === 404) return { versions: [], current_version: 0 };
    throw error;
  };
  const noRobot = (error) => {
    if (error instanceof ApiError && error.status === 404) return null;
    throw error;
  };
  const [history, robot] = await Promise.all([getJson(robotMapsPath(robotId)).catch(noHistory),
    getJson(`/api/robots/${encodeURIComponent(robotId)}`).catch(noRobot)]);
  if (!isCurrent()) return;
  const versions = history.versions;
  const open = (version) => { go(versionHash(robotId, version.version)); };
  main.append(h('p', { class: 'muted' }, h('a', { href: '#/maps' }, '← Maps')),
    h('h1', {}, `Map history — ${robotId}`),
    h('p', { class: 'muted' }, robot ? `${robot.robot_model} · firmware ${robot.firmware} · ` : '',
      `${versions.length} versions · current `, history.current_version ? h('a', { href: versionHash(robotId, history.current_version) }, `v${history.current_version}`) : 'none'));
  main.append(importCard(robotId));
  if (versions.length === 0) {
    main.append(emptyState('This robot has no map version yet.', 'A version is recorded when one of its runs is uploaded with a child map.'));
    setState(main, 'empty');
    return;
  }

  main.append(card('Timeline (click a version to review it)', h('div', { class: 'lineage-scroll' }, lineageTimeline(versions, { onOpen: open })), lineageLegend()));

  const newestFirst = [...versions].reverse();
  main.append(card('Versions, newest first', h('div', { class: 'table-scroll' }, h('table', { 'data-testid': 'versions-table' },
    h('tr', {}, ['version', 'what', 'by (UTC)', 'reason', 'review', 'nodes', 'edges (obs.)', 'components', 'known area m²', 'χ²', 'open findings']
      .map((t, i) => h('th', { class: i >= 5 ? 'num' : undefined }, t))),
    newestFirst.map((v) => {
      const same = sameMapAs(v, versions);
      return h('tr', { class: 'clickable', 'data-testid': 'version-row', 'data-version': v.version, onclick: () => open(v) },
        h('td', {}, h('a', { href: versionHash(robotId, v.version) }, `v${v.version}`), v.parent_version ? h('div', { class: 'muted' }, `from v${v.parent_version}`) : null),
        h('td', { class: 'wrap' }, h('strong', {}, originLabel(v)),
          v.origin === 'upload' && v.run_id ? [' · ', h('a', { href: `#/runs/${encodeURIComponent(v.run_id)}?robot=${encodeURIComponent(robotId)}`, onclick: (e) => e.stopPropagation() }, 'run')] : null,
          v.action_detail ? h('div', { class: 'muted' }, v.action_detail) : null,
          same && v.origin !== 'undo' ? h('div', { class: 'muted' }, `the map of v${same.version} again`) : null),
        h('td', {}, v.created_by, h('div', { class: 'muted' }, time(v.created_at * 1000))),
        h('td', { class: 'wrap' }, v.reason || ''),
        h('td', {}, approvalBadge(v, 'version-approval'), v.approved_by && v.approval !== 'pending' && !v.approved_by.startsWith('robot:') ? h('div', { class: 'muted' }, `by ${v.approved_by}`) : null),
        h('td', { class: 'num' }, num(v.nodes)), h('td', { class: 'num' }, `${num(v.edges)} (${num(v.observation_edges)})`),
        h('td', { class: 'num' }, num(v.components)), h('td', { class: 'num' }, num(v.known_area_m2, 1)),
        h('td', { class: 'num' }, num(v.chi2, 1)), h('td', { class: 'num' }, num(v.open_findings)));
    })))));
  setState(main, 'ready');
}

/// Upload a map made elsewhere as a new, pending version of this robot's map: a ValetudoMap export (the JSON
/// of "Export ValetudoMap" or GET /api/v2/robot/state/map), or a ROS map_server save (its YAML with the PGM or
/// PNG it names, sent together as a form). fleetd compares it with the previous version and lists what changed.
function importCard(robotId) {
  const input = h('input', { type: 'file', multiple: true, accept: '.json,application/json,.yaml,.yml,.pgm,.png', 'data-testid': 'import-file' });
  const status = h('span', { class: 'muted', 'data-testid': 'import-status' });
  const button = h('button', {
    'data-testid': 'import-button',
    onclick: async () => {
      const files = Array.from(input.files || []);
      const yaml = files.find((f) => /\.ya?ml$/i.test(f.name));
      const image = files.find((f) => /\.(pgm|png)$/i.test(f.name));
      const json = files.find((f) => /\.json$/i.test(f.name));
      if (!yaml && !json) { status.textContent = 'choose a ValetudoMap export (.json), or a map_server .yaml with its image'; return; }
      if (yaml && !image) { status.textContent = `choose the image ${yaml.name} names (.pgm or .png) together with it`; return; }
      status.textContent = `importing ${yaml ? `${yaml.name} + ${image.name}` : json.name} …`;
      try {
        let body;
        if (yaml) {
          body = new FormData();
          body.append('yaml', yaml, yaml.name);
          body.append('image', image, image.name);
        } else {
          body = JSON.parse(await json.text());
        }
        const { version } = await postAsEngineer(`${robotMapsPath(robotId)}/import`, body, 'Importing a map needs an engineer token.');
        go(versionHash(robotId, version.version));
      } catch (error) {
        status.textContent = `not imported: ${error.message}`;
      }
    },
  }, 'Import');
  return card('Import a map made elsewhere (ValetudoMap export .json, or map_server .yaml + .pgm/.png)', h('p', {}, input, ' ', button, ' ', status));
}
