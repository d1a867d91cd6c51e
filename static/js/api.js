// The REST calls the page makes (server/web/transformation.py): all SI, same origin.

const BUSY_TRIES = 3; // a server busy with others' requests says when to come back (503)

async function post( path, body ) {

	let response;
	for ( let attempt = 1; ; attempt ++ ) {

		response = await fetch( path, {
			method: 'POST',
			headers: { 'content-type': 'application/json' },
			body: JSON.stringify( body ),
		} );
		const wait = Number( response.headers.get( 'retry-after' ) );
		if ( response.status !== 503 || ! ( wait > 0 ) || attempt >= BUSY_TRIES ) break;
		await new Promise( ( resolve ) => setTimeout( resolve, Math.min( wait, 10 ) * 1000 ) );

	}
	let answer = null;
	try {

		answer = await response.json();

	} catch {

		answer = null;

	}
	return { status: response.status, ok: response.ok, body: answer };

}

function robotPath( name, what ) {

	return `/api/robots/${encodeURIComponent( name )}/${what}`;

}

/** Why a failed call failed, for people: the server's `detail` if it gave one. */
function reason( result ) {

	const detail = result.body && result.body.detail;
	if ( typeof detail === 'string' ) return detail;
	if ( Array.isArray( detail ) ) return detail.map( ( d ) => d.msg ).join( '; ' );
	return `HTTP ${result.status}`;

}

/** TCP poses (and, with `links`, every link's pose) of joint rows (rad or m). */
function forward( name, rows, links = false ) {

	return post( robotPath( name, 'fk' ), { joints: rows, links } );

}

/** Every configuration reaching `tcp` [x, y, z, qx, qy, qz, qw] (m), best nearest `joints`. */
function inverse( name, tcp, joints ) {

	return post( robotPath( name, 'ik' ), { tcp, joints_ref: joints, all: true } );

}

/** Command a move to `joints` (rad or m); 202 when accepted. */
function move( name, joints ) {

	return post( robotPath( name, 'move' ), { joints } );

}

/**
 * The last `minutes` of history as an MCAP file (server/web/history.py): a POST,
 * which a page on another site cannot send. `{ ok, blob, name }`, or `{ ok: false,
 * status, detail, retryAfter }` (503 while another recording is being saved).
 */
async function saveRecording( minutes ) {

	const response = await fetch( '/api/history/recording', {
		method: 'POST',
		headers: { 'content-type': 'application/json' },
		body: JSON.stringify( { minutes } ),
	} );
	if ( ! response.ok ) {

		let body = null;
		try {

			body = await response.json();

		} catch {

			body = null;

		}
		const retryAfter = Number( response.headers.get( 'retry-after' ) ) || null;
		return { ok: false, status: response.status, detail: reason( { status: response.status, body } ), retryAfter };

	}
	const disposition = response.headers.get( 'content-disposition' ) || '';
	const named = /filename="([^"]+)"/.exec( disposition );
	return { ok: true, blob: await response.blob(), name: named ? named[ 1 ] : 'linkview.mcap' };

}

/** Ask the server to measure clearance for the next 10 s (server/web/clearance.py). */
function wantClearance() {

	return post( '/api/clearance', {} );

}

export { forward, inverse, move, post, reason, saveRecording, wantClearance };
