// Protocol 2's binary frames message (server/protocol.py FRAMES_HEADER, ROBOT_HEADER):
// one message per data source and sample, holding every robot of that source.
// Little-endian, no padding. A plain ES module: the page imports it, and so does
// node in tests/web/test_protocol2_js.py.

const FRAMES_KIND = 1;
const FRAMES_VERSION = 3; // 3: joint_count is a u16 (a humanoid has more than 255 joints' room)
const FRAMES_HEADER_BYTES = 24; // u8 kind, u8 version, u16 robot_count, u32 seq, f64 t_source, f64 t_sent
const ROBOT_HEADER_BYTES = 10; // u16 robot_index, u8 flags, u8 zero, u16 joint_count, u16 link_count, u16 error_bytes
const POSE = 7; // x, y, z, qx, qy, qz, qw
const FLAG_OK = 1; // the robot has poses
const FLAG_SETPOINT = 2; // its setpoint pose follows the error text

const _utf8 = new TextDecoder( 'utf-8', { fatal: true } );

/** Whether `data` (an ArrayBuffer) starts like a protocol-2 frames message. */
function isFrames( data ) {

	if ( data.byteLength < 2 ) return false;
	const bytes = new Uint8Array( data, 0, 2 );
	return bytes[ 0 ] === FRAMES_KIND && bytes[ 1 ] === FRAMES_VERSION;

}

// Error text may have any length, so the floats after it need not be 4-byte
// aligned: a Float32Array view over the buffer would throw; read through a DataView.
function readFloats( view, at, count ) {

	const out = new Float32Array( count );
	for ( let i = 0; i < count; i ++ ) out[ i ] = view.getFloat32( at + 4 * i, true );
	return out;

}

/**
 * Decode a frames message (ArrayBuffer, or a typed array over one).
 * Returns `{ seq, t_source, t_sent, robots }`; each robot is `{ robot_index, ok,
 * joints, links, tcp, error, setpoint }` with `joints` (SI, hello order), `links`
 * (flat, 7 numbers per link: x, y, z, qx, qy, qz, qw, base frame) and `tcp` (7)
 * as Float32Arrays, `error` a string or null, and `setpoint` null or `{ joints,
 * links, tcp }` laid out the same way (robots whose joints have setpoint nodes).
 * Throws an Error for anything that is not exactly one such message, as
 * `decode_frames` in Python does.
 */
function decodeFrames( data ) {

	const view = ArrayBuffer.isView( data )
		? new DataView( data.buffer, data.byteOffset, data.byteLength )
		: new DataView( data );
	const size = view.byteLength;
	if ( size < FRAMES_HEADER_BYTES ) throw new Error( `${size} bytes is shorter than the frames header` );
	const kind = view.getUint8( 0 );
	const version = view.getUint8( 1 );
	if ( kind !== FRAMES_KIND || version !== FRAMES_VERSION ) {

		throw new Error( `not a protocol-2 frames message (kind ${kind}, version ${version})` );

	}
	const count = view.getUint16( 2, true );
	const seq = view.getUint32( 4, true );
	const tSource = view.getFloat64( 8, true );
	const tSent = view.getFloat64( 16, true );
	const robots = new Array( count );
	let at = FRAMES_HEADER_BYTES;
	for ( let r = 0; r < count; r ++ ) {

		if ( at + ROBOT_HEADER_BYTES > size ) throw new Error( `robot ${r} of ${count}: header cut off` );
		const index = view.getUint16( at, true );
		const flags = view.getUint8( at + 2 );
		const jointCount = view.getUint16( at + 4, true );
		const linkCount = view.getUint16( at + 6, true );
		const errorBytes = view.getUint16( at + 8, true );
		at += ROBOT_HEADER_BYTES;
		const floatCount = jointCount + POSE * linkCount + POSE;
		if ( at + 4 * floatCount + errorBytes > size ) throw new Error( `robot ${r} of ${count}: body cut off` );
		const joints = readFloats( view, at, jointCount );
		at += 4 * jointCount;
		const links = readFloats( view, at, POSE * linkCount );
		at += 4 * POSE * linkCount;
		const tcp = readFloats( view, at, POSE );
		at += 4 * POSE;
		const error = errorBytes > 0
			? _utf8.decode( new Uint8Array( view.buffer, view.byteOffset + at, errorBytes ) )
			: null;
		at += errorBytes;
		let setpoint = null;
		if ( flags & FLAG_SETPOINT ) {

			if ( at + 4 * floatCount > size ) throw new Error( `robot ${r} of ${count}: setpoint cut off` );
			setpoint = {
				joints: readFloats( view, at, jointCount ),
				links: readFloats( view, at + 4 * jointCount, POSE * linkCount ),
				tcp: readFloats( view, at + 4 * ( jointCount + POSE * linkCount ), POSE ),
			};
			at += 4 * floatCount;

		}
		robots[ r ] = { robot_index: index, ok: ( flags & FLAG_OK ) !== 0, joints, links, tcp, error, setpoint };

	}
	if ( at !== size ) throw new Error( `${size - at} bytes left over after ${count} robots` );
	return { seq, t_source: tSource, t_sent: tSent, robots };

}

export { FLAG_OK, FLAG_SETPOINT, FRAMES_HEADER_BYTES, FRAMES_KIND, FRAMES_VERSION, POSE, ROBOT_HEADER_BYTES, decodeFrames, isFrames };
