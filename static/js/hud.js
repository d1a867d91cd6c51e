import { Banner } from './banner.js';
import { button, checkbox, element, setText } from './dom.js';
import { NEAR_LIMIT } from './plots.js';
import { rpyFromQuaternion } from './rpy.js';
import { RAD_TO_DEG, clockTime, displayScale, fixed, formatJoint } from './units.js';

const MANY_JOINTS = 12; // more joints than this: a list that folds away and can be searched
const SHORT_NAME = 6; // characters: longer joint names get a row of their own width

/**
 * A long joint list (a humanoid, a dual-arm mobile manipulator) folded into a
 * `<details>` with a search field: typing part of a name shows only the joints
 * whose names hold it. Returns what goes into the card.
 */
function foldedJoints( robot, joints, rows ) {

	const details = element( 'details', 'joint-list' );
	const summary = element( 'summary', null, `${robot.joints.length} joints` );
	const search = element( 'input', 'joint-search' );
	search.type = 'search';
	search.placeholder = 'filter joints';
	search.setAttribute( 'aria-label', `filter the joints of ${robot.name}` );
	search.addEventListener( 'input', () => {

		const query = search.value.trim().toLowerCase();
		robot.joints.forEach( ( joint, k ) => {

			rows[ k ].row.hidden = query !== '' && ! joint.name.toLowerCase().includes( query );

		} );

	} );
	details.append( summary, search, joints );
	return details;

}

const SERVER_TEXT = {
	connecting: 'server: connecting',
	connected: 'server: connected',
	lost: 'server: lost, reconnecting',
};

/** Where a joint value sits between its limits (0..1), and whether it is within 5 % of one. */
function limitShare( value, joint ) {

	if ( ! joint.limits || ! Number.isFinite( value ) ) return null;
	const [ lo, hi ] = joint.limits;
	const share = ( value - lo ) / ( hi - lo );
	return { share: Math.min( Math.max( share, 0 ), 1 ), near: share < NEAR_LIMIT || share > 1 - NEAR_LIMIT };

}

/** What a robot's description holds that cannot be shown as written: folded, one line each. */
function warningList( warnings ) {

	const details = element( 'details', 'robot-warnings' );
	details.append( element( 'summary', null, warnings.length === 1 ? '1 warning' : `${warnings.length} warnings` ) );
	const list = element( 'ul' );
	for ( const text of warnings ) list.append( element( 'li', null, text ) );
	details.append( list );
	return details;

}

/**
 * The left panel: the server and controller pills, one card per robot (show,
 * trail, focus; TCP position in mm and roll/pitch/yaw in degrees; joint values
 * on bars between their limits; frames/s and latency; the description's
 * warnings), the data sources from
 * `status`, and the banner.
 */
class Hud {

	constructor( root, handlers ) {

		this.handlers = handlers; // { onShow(name, on), onTrail(name, on), onFocus(name) }
		this.serverPill = root.getElementById( 'pill-server' );
		this.controllersEl = root.getElementById( 'pill-controllers' );
		this.robotsEl = root.getElementById( 'robots' );
		this.sourcesEl = root.getElementById( 'sources' );
		this.sessionEl = root.getElementById( 'session' );
		this.banner = new Banner( root.getElementById( 'banner' ) );
		this.server = 'connecting';
		this.sources = new Map(); // source name -> its newest SourceStatus (one per message)
		this.cellError = null; // why the cell file on disk was not reloaded
		this._cards = new Map(); // robot name -> card elements and counters

	}

	setConnection( state ) {

		this.server = state;
		setText( this.serverPill, SERVER_TEXT[ state ] );
		this.serverPill.className = `pill pill-${state}`;
		// What the server last said about its sources is stale while we cannot hear it.
		this.sourcesEl.classList.toggle( 'stale', state !== 'connected' );
		this._renderPills();

	}

	/** One card per robot of `hello`; `views` supplies each robot's colour and choices. */
	setHello( hello, views ) {

		this.sessionEl.textContent = `session ${hello.session} · protocol ${hello.protocol}`;
		this.robotsEl.replaceChildren();
		const old = this._cards;
		this._cards = new Map();
		for ( const robot of hello.robots ) {

			const view = views.get( robot.name );
			const card = element( 'article', 'robot' );
			card.dataset.robot = robot.name;
			const title = element( 'div', 'robot-title' );
			const swatch = element( 'span', 'swatch' );
			const show = checkbox( 'show', view.shown, `show ${robot.name}` );
			show.input.addEventListener( 'change', () => this.handlers.onShow( robot.name, show.input.checked ) );
			const trail = checkbox( 'trail', view.trailOn, `draw the TCP trail of ${robot.name}` );
			trail.input.addEventListener( 'change', () => this.handlers.onTrail( robot.name, trail.input.checked ) );
			const focus = button( 'Focus', `focus the camera on ${robot.name}`, 'btn btn-small' );
			focus.addEventListener( 'click', () => this.handlers.onFocus( robot.name ) );
			title.append( swatch, element( 'span', 'name', robot.name ), element( 'span', 'kind', robot.kinematics ) );
			const controls = element( 'div', 'robot-controls' );
			controls.append( show.label, trail.label, focus );

			const tcp = element( 'div', 'tcp' );
			tcp.setAttribute( 'aria-label', `TCP of ${robot.name}` );
			const fields = {};
			for ( const [ key, unit ] of [ [ 'x', 'mm' ], [ 'y', 'mm' ], [ 'z', 'mm' ], [ 'roll', '°' ], [ 'pitch', '°' ], [ 'yaw', '°' ] ] ) {

				const cell = element( 'span', 'tcp-field' );
				const value = element( 'span', 'value', '—' );
				value.dataset.tcp = key;
				cell.append( element( 'span', 'name', key ), value, element( 'span', 'unit', unit ) );
				tcp.append( cell );
				fields[ key ] = value;

			}

			const joints = element( 'div', 'joints' );
			const rows = robot.joints.map( ( joint ) => {

				const row = element( 'div', 'joint' );
				const value = element( 'span', 'value', '—' );
				const bar = element( 'span', 'bar' );
				const mark = element( 'span', 'mark' );
				bar.append( mark );
				if ( joint.limits ) {

					const scale = displayScale( joint );
					bar.setAttribute( 'role', 'meter' );
					bar.setAttribute( 'aria-valuemin', String( joint.limits[ 0 ] * scale ) );
					bar.setAttribute( 'aria-valuemax', String( joint.limits[ 1 ] * scale ) );
					bar.setAttribute( 'aria-label', `${joint.name} between its limits` );
					bar.title = `limits ${formatJoint( joint.limits[ 0 ], joint )} … ${formatJoint( joint.limits[ 1 ], joint )}`;

				} else {

					bar.classList.add( 'unlimited' );
					bar.title = 'no limits';

				}
				const name = element( 'span', 'name', joint.name );
				name.title = joint.name;
				row.append( name, bar, value );
				joints.append( row );
				return { row, value, bar, mark };

			} );
			if ( robot.joints.some( ( joint ) => joint.name.length > SHORT_NAME ) ) joints.classList.add( 'long-names' );
			const many = robot.joints.length > MANY_JOINTS;
			const state = element( 'div', 'robot-state', 'waiting for the first frame' );
			const error = element( 'div', 'robot-error' );
			error.hidden = true;
			// Why its controller holds it still (a protective or emergency stop), while it does.
			const halted = element( 'div', 'robot-halted' );
			halted.hidden = true;
			card.append( title, controls, tcp, many ? foldedJoints( robot, joints, rows ) : joints, state, halted, error );
			if ( robot.warnings?.length ) card.append( warningList( robot.warnings ) );
			this.robotsEl.append( card );
			const before = old.get( robot.name );
			this._cards.set( robot.name, {
				card, swatch, show: show.input, trail: trail.input, fields, rows, state, halted, error,
				counted: view.framesReceived, since: undefined, time: - Infinity,
				rate: before ? before.rate : 0, shown: null,
			} );

		}
		this.refreshColors( views );

	}

	refreshColors( views ) {

		for ( const [ name, card ] of this._cards ) {

			const view = views.get( name );
			if ( view ) card.swatch.style.background = `#${view.color.getHexString()}`;

		}

	}

	setCell( notice ) {

		this.cellError = notice.error;

	}

	setStatus( status ) {

		for ( const source of status.sources ) this.sources.set( source.name, source );
		this.sourcesEl.replaceChildren();
		for ( const source of this.sources.values() ) {

			const item = element( 'li' );
			item.title = source.url;
			const age = source.last_sample_age_s === null ? '' : `${source.last_sample_age_s.toFixed( 2 )} s`;
			item.append(
				element( 'span', `dot dot-${source.state}` ),
				element( 'span', 'name', source.mock ? `${source.name} (mock)` : source.name ),
				element( 'span', 'muted', source.state ),
				element( 'span', 'age', age )
			);
			// The controller's address in plain sight: a commissioning engineer checks it first.
			item.append( element( 'span', 'address', source.url ) );
			if ( source.error ) item.append( element( 'span', 'error', source.error ) );
			if ( source.warning ) item.append( element( 'span', 'warning', source.warning ) );
			// What the device says of itself (a robot's mode, a protective stop), whatever its protocol.
			if ( source.device ) item.append( element( 'span', 'device', source.device ) );
			// "overloaded: N of M samples processed, R frames/s per robot": why robots move slower.
			if ( source.overloaded ) item.append( element( 'span', 'warning', source.overloaded ) );
			this.sourcesEl.append( item );

		}
		this._renderPills();

	}

	// One "controller" pill per data source, with its own state; unknown while the server is away.
	_renderPills() {

		const many = this.sources.size > 1;
		const pills = [];
		for ( const source of this.sources.values() ) {

			const state = this.server === 'connected' ? source.state : 'unknown';
			const pill = element( 'span', `pill pill-${state}`, `controller${many ? ` ${source.name}` : ''}: ${state}` );
			pill.title = [ source.url, source.error, source.device, source.warning ].filter( Boolean ).join( ' — ' );
			pill.dataset.source = source.name;
			pills.push( pill );

		}
		if ( pills.length === 0 ) pills.push( element( 'span', 'pill pill-unknown', 'controller: unknown' ) );
		this.controllersEl.replaceChildren( ...pills );

	}

	/** Whether robots of `sourceName` get live data now. */
	sourceLive( sourceName ) {

		const source = this.sources.get( sourceName );
		return this.server === 'connected' && source !== undefined && source.state === 'connected';

	}

	/** Refresh the cards and the banner (a few times a second). */
	update( views, clock, loadError, now = performance.now() ) {

		let robotProblem = null;
		for ( const [ name, card ] of this._cards ) {

			const view = views.get( name );
			if ( ! view ) continue;
			this._updateCard( card, view, clock, now );
			if ( view.error && ! robotProblem ) robotProblem = name;

		}
		this.banner.update( this._problem( loadError, robotProblem ), now );

	}

	_updateCard( card, view, clock, now ) {

		const robot = view.info;
		const frame = view.goodFrame;
		if ( frame && frame !== card.frame ) {

			card.frame = frame;
			robot.joints.forEach( ( joint, i ) => {

				const value = frame.joints[ i ];
				const row = card.rows[ i ];
				setText( row.value, formatJoint( value, joint ) );
				const where = limitShare( value, joint );
				if ( where ) {

					row.mark.style.left = `${( where.share * 100 ).toFixed( 1 )}%`;
					row.bar.classList.toggle( 'near', where.near );
					row.bar.setAttribute( 'aria-valuenow', ( value * displayScale( joint ) ).toFixed( 1 ) );

				}

			} );
			const tcp = frame.tcp;
			if ( tcp.length === 7 ) {

				const rpy = rpyFromQuaternion( tcp[ 3 ], tcp[ 4 ], tcp[ 5 ], tcp[ 6 ] );
				const text = {
					x: fixed( tcp[ 0 ] * 1000 ), y: fixed( tcp[ 1 ] * 1000 ), z: fixed( tcp[ 2 ] * 1000 ),
					roll: fixed( rpy[ 0 ] * RAD_TO_DEG ), pitch: fixed( rpy[ 1 ] * RAD_TO_DEG ), yaw: fixed( rpy[ 2 ] * RAD_TO_DEG ),
				};
				for ( const key in text ) setText( card.fields[ key ], text[ key ] );
				card.shown = { joints: Array.from( frame.joints ), tcp: text };

			}

		}
		const last = view.lastFrame;
		// Frames per second of sample time (t_source), not of arrival: after a stall the
		// browser hands over what it buffered in one burst, which is no faster a stream.
		if ( last && now - card.time >= 1000 ) {

			const span = card.since === undefined ? 0 : last.t_source - card.since;
			if ( span > 0 ) card.rate = ( view.framesReceived - card.counted ) / span;
			card.counted = view.framesReceived;
			card.since = last.t_source;
			card.time = now;

		}
		// While its controller sends nothing, the last rate and latency would be stale news.
		const source = this.sources.get( robot.source );
		const silent = source !== undefined && ( source.state === 'stale' || source.state === 'error' );
		if ( last && silent ) {

			const age = source.last_sample_age_s;
			const since = age === null ? 'no data' : `no data for ${age.toFixed( 0 )} s`;
			const good = view.goodFrame ? ` · last good at ${clockTime( view.goodFrame.t_source )}` : '';
			setText( card.state, since + good );

		} else if ( last ) {

			const latency = view.latencyMs === null ? '—' : `${view.latencyMs.toFixed( 0 )} ms`;
			setText( card.state, `${card.rate.toFixed( 0 )} frames/s · latency ${latency}` );

		} else if ( view.zeroPosed ) {

			setText( card.state, 'no frame yet: shown at its zero pose' );

		}
		card.card.classList.toggle( 'greyed', view.greyed || silent );
		const halted = source?.halted ?? null;
		card.halted.hidden = halted === null;
		setText( card.halted, halted === null ? '' : `held by its controller: ${halted}` );
		card.error.hidden = view.error === null;
		setText( card.error, view.error ?? '' );

	}

	// The one most important thing, worded so it stays the same while it lasts.
	_problem( loadError, robotProblem ) {

		if ( this.server === 'connecting' ) return { text: 'Connecting to the linkview server…', warn: true, urgent: true };
		if ( this.server === 'lost' ) return { text: 'Connection to the linkview server lost — reconnecting…', urgent: true };
		if ( loadError ) return { text: loadError };
		if ( this.cellError ) return { text: `The cell file was not reloaded: ${this.cellError}` };
		for ( const source of this.sources.values() ) {

			if ( source.state === 'error' ) return { text: `Controller ${source.name}: ${source.error || 'in error'}` };
			if ( source.state === 'stale' ) return { text: `Controller ${source.name} sends no new data — showing the last good pose`, warn: true };
			if ( source.state === 'connecting' ) return { text: `Connecting to controller ${source.name}…`, warn: true };
			if ( source.halted ) return { text: `Controller ${source.name} holds its robots: ${source.halted}`, warn: true };

		}
		if ( robotProblem ) return { text: `${robotProblem} cannot be posed: see the error beside it`, warn: true };
		// No figures here: the banner's text must not change while the overload lasts.
		for ( const source of this.sources.values() ) {

			if ( source.overloaded ) return { text: 'The server cannot keep up: robots move at a reduced rate (see the data sources)', warn: true };

		}
		return null;

	}

	/** What a robot's card shows now (tests compare it with /fk). */
	shown( name ) {

		const card = this._cards.get( name );
		return card ? card.shown : null;

	}

}

export { Hud };
