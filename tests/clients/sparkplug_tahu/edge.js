// An edge node as Eclipse Tahu's sparkplug-client publishes it: NBIRTH, a device's
// DBIRTH and its DDATA every period, for linkview's Sparkplug B tests.
//
//   node edge.js '{"url": "tcp://127.0.0.1:1883", "group": "G", "edge": "E", "device": "D",
//                  "metrics": [{"name": "Axis 1/Position", "alias": 1, "type": "Double"}],
//                  "periodMs": 20, "aliasesOnly": false, "compress": null}'
//
// Metric i's value at time t (s) is 0.5 sin(t) + offset (i unless the metric gives its
// "offset"; integer types round it). Lines on stdin:
// "ddeath" publishes the device's DDEATH, "dbirth" its DBIRTH again, "stop" ends with the
// node's NDEATH.
'use strict';

const readline = require('readline');
const sparkplug = require('sparkplug-client');

const config = JSON.parse(process.argv[2]);
const client = sparkplug.newClient({
	serverUrl: config.url,
	username: '',
	password: '',
	groupId: config.group,
	edgeNode: config.edge,
	clientId: `linkview-test-${process.pid}`,
	publishDeath: true,
	version: 'spBv1.0',
});
const options = config.compress ? { compress: true, algorithm: config.compress } : {};
const started = Date.now();
let alive = false;

function values(withNames) {
	const t = (Date.now() - started) / 1000;
	return config.metrics.map((m, i) => {
		const raw = 0.5 * Math.sin(t) + (m.offset ?? i);
		const metric = { value: /Int/.test(m.type) ? Math.round(raw) : raw, type: m.type };
		if (withNames || !config.aliasesOnly || m.alias === undefined) metric.name = m.name;
		if (m.alias !== undefined) metric.alias = m.alias;
		return metric;
	});
}

function births() {
	client.publishNodeBirth({ timestamp: Date.now(), metrics: [] }, options);
	client.publishDeviceBirth(config.device, { timestamp: Date.now(), metrics: values(true) }, options);
	alive = true;
}

client.on('birth', births);
client.on('error', (error) => console.error(`sparkplug-client: ${error}`));

setInterval(() => {
	if (alive) client.publishDeviceData(config.device, { timestamp: Date.now(), metrics: values(false) }, options);
}, config.periodMs || 20);

readline.createInterface({ input: process.stdin }).on('line', (line) => {
	const command = line.trim();
	if (command === 'ddeath') {
		alive = false;
		client.publishDeviceDeath(config.device, { timestamp: Date.now() });
	} else if (command === 'dbirth') {
		client.publishDeviceBirth(config.device, { timestamp: Date.now(), metrics: values(true) }, options);
		alive = true;
		} else if (command === 'stop') {
		alive = false;
		client.stop();
		setTimeout(() => process.exit(0), 200);
	}
}).on('close', () => process.exit(0));
