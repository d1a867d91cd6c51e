// SI inside; degrees and millimetres only where people read them.

const RAD_TO_DEG = 180 / Math.PI;

/** Factor from a joint's SI unit (rad or m) to what the page shows (deg or mm). */
function displayScale( joint ) {

	return joint.unit === 'm' ? 1000 : RAD_TO_DEG;

}

function displayUnit( joint ) {

	return joint.unit === 'm' ? 'mm' : '°';

}

/** `value.toFixed(digits)`, without the "-0.0" of tiny negatives. */
function fixed( value, digits = 1 ) {

	const text = value.toFixed( digits );
	return Number( text ) === 0 ? ( 0 ).toFixed( digits ) : text;

}

/** A joint value for people: degrees for rotary joints, millimetres for linear ones. */
function formatJoint( value, joint ) {

	if ( ! Number.isFinite( value ) ) return '—';
	return `${fixed( value * displayScale( joint ) )}${joint.unit === 'm' ? ' mm' : '°'}`;

}

// One formatter, made once: toLocaleTimeString builds a new one per call, which cost the
// page 5 ms of script a second at the readouts' 10 Hz (the timeline's range).
const TIME_OF_DAY = new Intl.DateTimeFormat( [], { hour: 'numeric', minute: '2-digit', second: '2-digit', hour12: false } );

/** Wall-clock time of unix seconds `t`, as the viewer's clock reads it (HH:MM:SS). */
function clockTime( t ) {

	return TIME_OF_DAY.format( new Date( t * 1000 ) );

}

export { RAD_TO_DEG, clockTime, displayScale, displayUnit, fixed, formatJoint };
