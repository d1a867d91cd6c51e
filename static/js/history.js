// GET /api/history (server/web/history.py, docs/protocol.md): the timeline's span and
// marks, and windows of samples in the binary layout of server/history/encode.py.

const MAGIC = 'LVH1';
const _utf8 = new TextDecoder( 'utf-8' );
const ARRAYS = { f64: Float64Array, f32: Float32Array, u32: Uint32Array, u8: Uint8Array };

/**
 * Decode a binary history window (an ArrayBuffer). Returns its header with every
 * array entry replaced by a typed array viewing the buffer in place: `t` (unix s),
 * `seq`, and per robot `ok`, `joints` (n × joints, SI), `tcp` (n × 7) and `links`
 * (n × links × 7, base frame), the last two null when not asked for.
 */
function decodeWindow( buffer ) {

	const view = new DataView( buffer );
	if ( buffer.byteLength < 8 || _utf8.decode( new Uint8Array( buffer, 0, 4 ) ) !== MAGIC ) throw new Error( 'not a linkview history window' );
	const size = view.getUint32( 4, true );
	const header = JSON.parse( _utf8.decode( new Uint8Array( buffer, 8, size ) ) );
	const body = 8 + size;
	const load = ( entry ) => {

		if ( ! entry ) return null;
		const count = entry.shape.reduce( ( a, b ) => a * b, 1 );
		return new ARRAYS[ entry.type ]( buffer, body + entry.offset, count );

	};
	header.t = load( header.t );
	header.seq = load( header.seq );
	for ( const entry of header.robots ) {

		entry.jointCount = entry.joints.shape[ 1 ] ?? 0;
		entry.linkCount = entry.links ? entry.links.shape[ 1 ] : 0;
		for ( const key of [ 'ok', 'joints', 'tcp', 'links' ] ) entry[ key ] = load( entry[ key ] );

	}
	return header;

}

/** Every kept's span (`from`, `to`, unix s) and the marks; null when the server says no. */
async function fetchSummary() {

	const response = await fetch( '/api/history' );
	return response.ok ? response.json() : null;

}

/** A window of `kept` from `from` to `to` (unix s) with link poses, decoded. */
async function fetchWindow( kept, from, to, poses = 'links' ) {

	const query = new URLSearchParams( { source: kept, from: String( from ), to: String( to ), poses } );
	const response = await fetch( `/api/history?${query}` );
	if ( ! response.ok ) throw new Error( `history of ${kept}: HTTP ${response.status}` );
	return decodeWindow( await response.arrayBuffer() );

}

/** The index of the last sample at or before `t` in sorted `times`, or -1. */
function lastAtOrBefore( times, t ) {

	let lo = 0;
	let hi = times.length;
	while ( lo < hi ) {

		const mid = ( lo + hi ) >> 1;
		if ( times[ mid ] <= t ) lo = mid + 1;
		else hi = mid;

	}
	return lo - 1;

}

export { decodeWindow, fetchSummary, fetchWindow, lastAtOrBefore };
