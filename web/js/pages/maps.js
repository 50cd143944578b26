// Maps: every robot with its map history in brief (versions, the current one, the newest and its review
// state, open findings, versions waiting for review); a row opens the robot's history.
import { getJson } from '../api.js';
import { card, emptyState, go, h, num, setState } from '../ui.js';
import { historyHash } from '../maphistory.js';

export async function render(main, { isCurrent }) {
  const { robots } = await getJson('/api/robots');
  if (!isCurrent()) return;
  main.append(h('h1', {}, 'Maps'),
    h('p', { class: 'muted' }, 'Each robot\'s map history: uploads, repairs, rollbacks and undos. Robots get the current version (the newest approved one); repairs wait for an engineer\'s review.'));
  if (robots.length === 0) {
    main.append(emptyState('No robots yet.', 'A robot appears with its first upload (fleetsim --upload …).'));
    setState(main, 'empty');
    return;
  }
  const rows = robots.map((robot) => h('tr', { class: 'clickable', 'data-testid': 'robot-row', 'data-robot': robot.robot_id,
    onclick: () => { go(historyHash(robot.robot_id)); } },
  h('td', {}, h('a', { href: historyHash(robot.robot_id) }, robot.robot_id)),
  h('td', {}, robot.robot_model), h('td', {}, robot.firmware),
  h('td', { class: 'num' }, num(robot.versions)),
  h('td', { class: 'num' }, robot.current_version ? `v${robot.current_version}` : 'none'),
  h('td', {}, robot.head_version ? [`v${robot.head_version} `, h('span', { class: `badge ${robot.head_version === robot.current_version ? 'current' : robot.head_approval}` }, robot.head_approval)] : '—'),
  h('td', { class: 'num' }, robot.open_findings === undefined ? '—' : num(robot.open_findings)),
  h('td', { class: 'num' }, robot.pending ? h('span', { class: 'badge pending' }, robot.pending) : '0')));
  main.append(card(`Robots (${robots.length})`, h('table', { 'data-testid': 'robots-table' },
    h('tr', {}, ['robot', 'model', 'firmware', 'versions', 'current', 'newest (review)', 'open findings (newest)', 'pending review']
      .map((t, i) => h('th', { class: i >= 3 && i !== 5 ? 'num' : undefined }, t))),
    rows)));
  setState(main, 'ready');
}
